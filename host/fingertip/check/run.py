"""The bring-up sequence: link, chips and rate, rest (noise, pick-up, balance), the 10 SPS
rate, the guided presses, the taps, the rest again (drift), the counters.

:func:`run_check` needs an open :class:`~.probe.DeviceProbe`, a guide, and optionally an
audio capture (anything with ``start(t)``, ``stop(t) -> (samples, t0)``, ``sample_rate``
and ``name``); it returns a :class:`~.results.Report`.
"""
from __future__ import annotations

import logging
import time
from collections.abc import Callable

import numpy as np

from ..device import FingertipError
from ..protocol import PROTOCOL_MAJOR
from . import signals as S
from .guide import Guide
from .piezo import check_piezo, force_tap_times
from .results import FAIL, PASS, SKIP, WARN, Report, Result

log = logging.getLogger(__name__)

REST_S = 2.5
SLOW_S = 1.2
SETTLE_S = 0.6
PRESS_S = {True: 3.0, False: 1.6}
"""Recording per press: a person (interactive) needs longer than the simulator."""
TAP_S = {True: 3.5, False: 1.6}
TAPS = 3
END_REST_S = 1.0


def run_check(probe, guide: Guide, audio=None, *,
              progress: Callable[[str], None] | None = None) -> Report:
    say = progress or (lambda _m: None)
    t_start = time.monotonic()
    rep = Report(device=probe.describe())
    info = probe.info
    rep.add(Result("protocol version", PASS if info.protocol_major == PROTOCOL_MAJOR else FAIL,
                   f"v{info.protocol_major}.{info.protocol_minor}", f"v{PROTOCOL_MAJOR}.x",
                   fix="flash the firmware that matches this host (fingertip flash)"))
    rep.add(Result("firmware", PASS, f"{rep.device['firmware']} build "
                   f"{rep.device['build_id']}", ""))
    probe.prepare()
    try:
        _run(probe, guide, audio, rep, say)
    except FingertipError as e:
        rep.add(Result("link", FAIL, f"the device stopped answering: {e}", "answers",
                       fix="check the USB cable and hub; run the check again"))
    finally:
        probe.restore()
    rep.seconds = time.monotonic() - t_start
    return rep


def _run(probe, guide: Guide, audio, rep: Report, say) -> None:
    gain = probe.gain
    say("recording at rest (80 SPS) ...")
    probe.capture(0.3)  # let the chips settle after the rate command
    rest = probe.capture(REST_S)
    rep.recorded["rest"] = rest
    chips = S.check_chips(rest)
    rep.add(chips)
    bad = {r.channel for r in chips if r.status == FAIL}
    rep.add(S.check_rate(rest, 80))
    stuck = S.check_stuck(rest, bad)
    rep.add(stuck)
    bad |= {r.channel for r in stuck if r.status == FAIL}
    bal = S.check_balance(rest, bad)
    rep.add(bal)
    bad |= {r.channel for r in bal if r.status == FAIL}
    rep.add(S.check_noise(rest, 80, gain, bad))
    rep.add(S.check_mains(rest, 80, gain, bad))
    rep.add(S.check_drift(rest, 80, gain, bad))
    noise = np.array([S.noise_rms(rest, ch) if ch not in bad else np.inf
                      for ch in range(rest.channels)])
    noise = np.where(np.isfinite(noise), noise, 1e9)

    say("recording at 10 SPS ...")
    probe.set_rate(10)
    probe.capture(SETTLE_S)
    rep.add(S.check_rate(probe.capture(SLOW_S), 10))
    probe.set_rate(80)
    probe.capture(0.3)

    if rest.channels == 4:
        _presses(probe, guide, rep, noise, bad, say)
    else:
        rep.add(Result("channel mapping", SKIP, f"{rest.channels} channels",
                       "checked per 4-channel fingertip"))
    _taps(probe, guide, audio, rep, noise, bad, say)

    end = probe.capture(END_REST_S)
    press = None if rep.mapping is None else np.array(rep.mapping["press_counts"])
    rep.add(S.check_return(rest, end, press, bad))

    counters = probe.counters()
    if counters is None:
        rep.add(Result("link counters", WARN, "no answer to GET_STATS", "an answer",
                       fix="the device did not answer in time: another cable, a powered hub"))
        return
    dirty = {k: v for k, v in counters.items() if v}
    rep.add(Result("link counters", WARN if dirty else PASS,
                   ", ".join(f"{k}={v}" for k, v in dirty.items()) or "all zero", "all zero",
                   fix="bytes are lost or corrupted on the USB link: another cable, a "
                       "powered hub, no other program on the port" if dirty else "",
                   data=counters))


def _acting_from(guide: Guide, called: float) -> dict[str, float]:
    """From when the guide's action may begin, as :meth:`~.probe.DeviceProbe.capture`'s
    ``since`` (``time.monotonic()``: a person acts after the prompt returns, "GO") or, for a
    simulated guide that knows it, ``since_device_s``: the device's own time when the step
    was asked. A simulated device can lag its pace on a busy host, and a busy host's reader
    can hand over frames late: the device's clock says which frames came after the request
    in both cases. The capture keeps every frame from then on, queued ones included."""
    device_s = getattr(guide, "acted_at_s", None)
    if device_s is not None:
        return {"since_device_s": float(device_s)}
    return {"since": time.monotonic() if guide.interactive else called}


def _presses(probe, guide: Guide, rep: Report, noise, bad, say) -> None:
    responses: dict[int, np.ndarray | None] = {}
    for face, label in enumerate(S.FACES):
        asked = time.monotonic()
        if not guide.press(face, label):
            rep.skipped_steps.append(f"press {label} (polarity, mapping, sensitivity)")
            continue
        start = _acting_from(guide, asked)
        say(f"press {label} ...")
        seg = probe.capture(PRESS_S[guide.interactive], **start)
        responses[face] = S.press_response(seg, noise, bad)
    rep.recorded["responses"] = responses
    if not responses:
        rep.add(Result("polarity and mapping", SKIP, "presses skipped", ""))
        return
    res, mapping = S.check_presses(responses, bad)
    rep.add(res)
    rep.mapping = mapping


def _taps(probe, guide: Guide, audio, rep: Report, noise, bad, say) -> None:
    if audio is None:
        rep.add(Result("piezo", SKIP, "no sound card", "", fix=""))
        return
    audio.start(probe.last_time_s)
    asked = time.monotonic()
    if not guide.tap(TAPS):
        audio.stop(probe.last_time_s)
        rep.skipped_steps.append("tap the nail (piezo level, clipping, delay)")
        rep.add(Result("piezo", SKIP, "taps skipped", ""))
        return
    start = _acting_from(guide, asked)
    say("tapping ...")
    seg = probe.capture(TAP_S[guide.interactive], **start)
    x, t0 = audio.stop(probe.last_time_s)
    taps = force_tap_times(seg, noise, bad)
    rep.add(check_piezo(x, audio.sample_rate, t0, taps, TAPS, audio.name))
