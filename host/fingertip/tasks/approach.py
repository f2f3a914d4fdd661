"""Close the fingers at a set speed until each one touches: the fast first phase of a grip.

The paper's controller closes by one small step per force frame, so its closing speed is
bound to the frame rate and to how far a finger may overshoot before the next frame shows
the force. :func:`approach` instead starts every finger at ``speed_mm_s``
(:meth:`~.interfaces.RobotHand.move`) and stops each one the moment its contact detector
reports ``contact`` (a :class:`~.interfaces.ContactSource`: force frames alone, or the
piezo's onset confirmed by force); :meth:`~.grip.Grip.close` then regulates to ``F_th``
with the fine steps as before.

With a source that needs audio the loop waits at most ``poll_s`` for a force frame, then
takes each moving finger's new piezo samples, so a touch is acted on within one audio block
of being heard; without audio it waits for each force frame. Aborts (no frames, a flagged
frame, a force above the grip's ``max_force``, the grip's timeout) go through the grip:
every finger stops and opens.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field

from .grip import Grip, PinchOutcome
from .interfaces import ContactSource

log = logging.getLogger(__name__)

POLL_S = 64 / 44100
"""Audio block length the loop polls at (64 samples at 44.1 kHz: a small ALSA period)."""


@dataclass
class ApproachResult:
    ok: bool = True
    contacts: dict[str, object] = field(default_factory=dict)
    """Each finger's first contact event (``time``, ``detected_at``, ``source``)."""
    stop_s: dict[str, float] = field(default_factory=dict)
    """When each finger's stop was commanded (the clock of the frames and audio)."""


def approach(grip: Grip, speed_mm_s: float, contact: ContactSource,
             poll_s: float = POLL_S) -> ApproachResult:
    """Close ``grip``'s fingers at ``speed_mm_s`` until each touches (see the module
    text); call after :meth:`~.grip.Grip.zero`. ``ok`` is False after an abort."""
    if not speed_mm_s > 0:
        raise ValueError(f"approach speed must be > 0 mm/s, not {speed_mm_s}")
    if not grip.zeroed:
        raise RuntimeError("zero the grip (fingers open) before the approach")
    hand, cfg = grip.hand, grip.cfg
    res = ApproachResult()
    left = list(grip.fingers)
    audio = contact.needs_audio
    if audio:
        for f in left:
            hand.read_audio(f)                  # start each capture now
    clock = last_frame = grip.now
    hand.move(dict.fromkeys(left, speed_mm_s))
    contact.motion(clock, left)

    def stop_all(outcome: PinchOutcome, detail: str) -> ApproachResult:
        hand.move(dict.fromkeys(grip.fingers, 0.0))
        grip.abort(outcome, detail)
        res.ok = False
        return res

    while left:
        frames = hand.read(poll_s if audio else cfg.read_timeout_s)
        events = []
        if frames is not None:
            forces = grip.forces(frames)
            if forces is None:
                hand.move(dict.fromkeys(grip.fingers, 0.0))
                res.ok = False
                return res
            last_frame = clock = max(clock, grip.now)
            for f in left:
                events += contact.feed_force(f, frames[f].host_time, forces[f])
        elif not audio:
            return stop_all(PinchOutcome.SENSOR_FAULT, "no frames")
        if audio:
            for f in left:
                blk = hand.read_audio(f)
                events += contact.feed_audio(f, blk.samples, blk.t0)
                clock = max(clock, blk.t_end)
            if clock - last_frame > cfg.read_timeout_s:
                return stop_all(PinchOutcome.SENSOR_FAULT, "no frames")
        touched = []
        for f, ev in events:
            if ev.kind == "contact" and f in left and f not in touched:
                touched.append(f)
                res.contacts[f] = ev
                res.stop_s[f] = clock
        if touched:
            hand.move(dict.fromkeys(touched, 0.0))
            left = [f for f in left if f not in touched]
        t0 = grip.started_at
        if t0 is not None and clock - t0 > cfg.timeout_s:
            return stop_all(PinchOutcome.TIMEOUT, f"no contact on {left} after "
                                                  f"{clock - t0:.2f} s of approach")
    log.debug("approach at %g mm/s: contacts %s", speed_mm_s,
              {f: round(e.latency_s * 1e3, 2) for f, e in res.contacts.items()})
    return res
