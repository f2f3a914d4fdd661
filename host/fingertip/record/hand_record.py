"""``fingertip record --hand ... | --port P --hand-split 4x4``: every finger of a hand on its
own topics (``/fingertip/<finger>/raw``, ``wrench``, ``audio``, ``events``) of one MCAP file,
with the settings and the loop of :mod:`.session`."""
from __future__ import annotations

import contextlib
import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..hand_args import HandSpec
from .session import RecordSettings, Say, run_until

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class HandSummary:
    """What a hand's session wrote, per finger; :attr:`error` is set when writing failed
    part-way."""

    output: Path
    elapsed_s: float
    per_finger: dict[str, dict[str, int]]   # finger -> raw, wrench, audio, events, audio_frames
    dropped: int
    dropped_by_topic: dict[str, int]
    megabytes: float
    frames_lost: int
    """Frames the devices lost (sequence gaps and outages), summed over the hand's devices."""
    crc_errors: int
    reconnects: int
    error: str | None = None
    device_resets: int = 0
    outage_frames: int = 0
    gone: dict[str, float] | None = None
    """Finger -> seconds its device had been away when the session ended."""

    def text(self) -> str:
        from ..device.health import gone_text, link_text

        lines = [f"{f}: {c['raw']} frames, {c['wrench']} forces, {c['audio_frames']} audio "
                 f"frames in {c['audio']} chunks, {c['events']} events"
                 for f, c in self.per_finger.items()]
        drops = ", ".join(f"{k}: {v}" for k, v in sorted(self.dropped_by_topic.items()))
        lines.append(f"recorded {self.elapsed_s:.1f} s to {self.output}: dropped {self.dropped}"
                     + (f" ({drops})" if drops else "") + "; "
                     f"{self.megabytes:.2f} MB; devices: {link_text(self)}"
                     + "".join(gone_text(f, s) for f, s in (self.gone or {}).items()))
        return "\n".join(lines)


def record_hand(settings: RecordSettings, spec: HandSpec, audio: list, force_model: Any = None,
                say: Say | None = None) -> HandSummary:
    """Record the hand ``spec`` describes and its microphones (``audio``: (source, finger
    names) pairs, not started) until the settings' duration, SIGTERM or Ctrl-C. Raises the
    devices', recorder's and audio errors (and ValueError for a split that names channels
    the device does not have); everything opened is closed whatever happens."""
    from ..device import FingertipError, SharedReader
    from ..device.health import GoneReporter

    # The recorder takes frames by callback: queues nobody reads would only count phantom
    # overruns, and one thread reads every device of the hand.
    hand = spec.build(callbacks_only=True, reader=SharedReader())
    rec = None
    try:
        hand.open()  # refuses a split that names channels the device does not have
        if settings.tare:
            hand.tare(samples=settings.tare)
        rec = settings.recorder()
        rec.start()
        for finger in hand.fingers:
            dev = hand.device(finger)
            info = {"name": finger, "port": dev.port, "serial_number": dev.serial_number,
                    "channels": list(spec.groups[finger]) if spec.groups else None}
            rec.add_device(finger, info=info, force_model=force_model, device=dev)
        hand.add_callback(rec.write_frame)
        for source, names in audio:
            source.start()
            if len(names) == 1 and source.channels == 1:
                rec.record_audio(source, names[0])
            else:
                rec.record_audio_split(source, names)
        hand.start()
        for finger in hand.fingers:
            rec.write_event(finger, "start")
        if say is not None:
            say(settings.announce(f"hand ({', '.join(hand.fingers)})"))
        gone = GoneReporter()

        def tick(_seconds: float) -> None:
            for finger in hand.fingers:
                dev = hand.device(finger)
                gone.check(finger, dev.gone_s, dev.port)
        elapsed = run_until(settings.duration, rec, tick)
        with contextlib.suppress(FingertipError):
            hand.stop()
        hand.remove_callback(rec.write_frame)
        for finger in hand.fingers:
            rec.write_event(finger, "stop")
        for source, _ in audio:   # before the recorder closes: what they captured is recorded
            source.stop()
        s = rec.close()
        stats = [d.stats for d in hand.devices]
        per = {f: {k: s.written.get(f"/fingertip/{f}/{k}", 0)
                   for k in ("raw", "wrench", "audio", "events")} for f in hand.fingers}
        for f, c in per.items():
            c["audio_frames"] = s.audio_frames.get(f, 0)
        return HandSummary(output=settings.output, elapsed_s=elapsed, per_finger=per,
                           dropped=s.dropped_total, dropped_by_topic=dict(s.dropped),
                           megabytes=s.bytes_written / 1e6,
                           frames_lost=sum(st.frames_lost for st in stats),
                           crc_errors=sum(st.crc_errors for st in stats),
                           reconnects=sum(st.reconnects for st in stats),
                           error=None if rec.error is None else str(rec.error),
                           device_resets=sum(st.device_resets for st in stats),
                           outage_frames=sum(st.outage_frames for st in stats),
                           gone={f: g for f in hand.fingers
                                 if (g := hand.device(f).gone_s) is not None})
    finally:
        for source, _ in audio:
            source.stop()
        if rec is not None:
            rec.close()
        hand.close()
