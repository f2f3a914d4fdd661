"""Cost of the virtual fingertip: simulated seconds per wall second.

- ``sim_realtime_factor_<scene>`` for the standard scenes (press, slide 5 s, contact, cups,
  shake), from :func:`studies.sim_speed.scene_realtime_factors` (median of
  repeats, whole ``simulate`` call).
- One scene, the press, as force only (its default) and as force + vibration, measured
  side by side: what "model only what a scene needs" saves.
- ``sim_twin_device_us_per_frame``: CPU time of the virtual device alone (VirtualFirmware:
  the firmware's C++ through the device library), 4 channels streaming at 80 SPS, a constant
  source, advanced one frame at a time, bytes not decoded: what the device logic costs.
- ``sim_twin_device_realtime_factor``: the virtual device (VirtualFirmware, 4 channels,
  80 SPS, streaming) with a physics source (a virtual unit under a press), advanced as fast
  as possible in 10 ms steps, its bytes decoded by the host's StreamDecoder as a bridge
  would; simulated seconds per wall second.

Single thread, pinned to one core where possible.
"""
from __future__ import annotations

import os
import statistics
import time
from dataclasses import replace

from fingertip.protocol import Sample, Start, StreamDecoder, encode
from fingertip.sim import VirtualFirmware
from fingertip.sim.physics import FORCE, VIBRATION, Press, VirtualStrainSensor
from studies.sim_speed import STANDARD_SCENES, realtime_factor, scene_realtime_factors

REPEATS = 3
TWIN_SECONDS = 10.0
TWIN_STEP_US = 10_000


def twin_realtime_factor(seconds: float = TWIN_SECONDS, seed: int = 1) -> float:
    """Simulated seconds per wall second of the twin device fed by the physics."""
    scene = Press(angle_deg=20, height_mm=2, peak_n=5.0)
    fw = VirtualFirmware(4, source=VirtualStrainSensor(seed).as_source(scene))
    dec = StreamDecoder("device")
    w0 = time.perf_counter()
    dec.feed(fw.boot())
    dec.feed(fw.receive(encode(Start(1))))
    end_us = int(seconds * 1e6)
    samples = 0
    t = 0
    while t < end_us:
        t += TWIN_STEP_US
        for m in dec.feed(fw.advance(t)):
            samples += isinstance(m, Sample)
    wall = time.perf_counter() - w0
    assert dec.stats.errors_total == 0 and fw.rate_sps == 80
    assert abs(samples - seconds * 80) <= 8, samples  # 80 SPS, after the chips settle
    return seconds / wall


def twin_us_per_frame(seconds: float = 20.0) -> float:
    """CPU microseconds per SAMPLE frame of the virtual device alone."""
    fw = VirtualFirmware(4, source=lambda t: (1000, -2000, 3000, 4))
    fw.boot()
    fw.receive(encode(Start(1)))
    c0 = time.process_time()
    t, n = 0, 0
    while t < seconds * 1e6:
        t += 12_500
        n += len(fw.advance(t)) > 0
    return (time.process_time() - c0) / n * 1e6


def run() -> dict[str, float]:
    try:
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    except (AttributeError, OSError):
        pass
    out: dict[str, float] = dict(scene_realtime_factors(repeats=REPEATS))
    press = STANDARD_SCENES["press"]()
    force_only = realtime_factor(replace(press, signals=(FORCE,)), repeats=REPEATS)
    both = realtime_factor(replace(press, signals=(FORCE, VIBRATION)), repeats=REPEATS)
    out["sim_realtime_factor_press_force_only"] = round(force_only, 2)
    out["sim_realtime_factor_press_force_vibration"] = round(both, 2)
    out["sim_press_vibration_cost_ratio"] = round(force_only / both, 1)
    out["sim_twin_device_us_per_frame"] = round(
        statistics.median(twin_us_per_frame() for _ in range(5)), 2)
    twin_realtime_factor(1.0)  # warm up
    out["sim_twin_device_realtime_factor"] = round(
        statistics.median(twin_realtime_factor() for _ in range(REPEATS)), 2)
    return out


DESCRIPTION = {
    "sim_realtime_factor_press": ("simulated s per wall s: press 0-5 N at 20 deg, 2 mm "
                                  "(force only)", None),
    "sim_realtime_factor_slide": ("simulated s per wall s: 5 s slide over coarse fabric "
                                  "(vibration at 44.1 kHz)", None),
    "sim_realtime_factor_contact": ("simulated s per wall s: 3 touches (force and vibration)",
                                    None),
    "sim_realtime_factor_cups": ("simulated s per wall s: slide down 5 cups, 3 rims "
                                 "(vibration)", None),
    "sim_realtime_factor_shake": ("simulated s per wall s: box of screws shaken 5.6 s "
                                  "(vibration)", None),
    "sim_realtime_factor_press_force_only": ("the same press, force only (its default), "
                                             "measured beside the next one", None),
    "sim_realtime_factor_press_force_vibration": ("the same press with the vibration "
                                                  "channel as well", None),
    "sim_press_vibration_cost_ratio": ("how many times cheaper the force-only press is: what "
                                       "'model only what a scene needs' saves", (">", 1.0)),
    "sim_twin_device_us_per_frame": ("CPU us per frame of the virtual device alone (the "
                                     "firmware's C++ via ctypes), 4 channels, 80 SPS", None),
    "sim_twin_device_realtime_factor": ("simulated s per wall s: the virtual device, 4 "
                                        "channels, 80 SPS, physics source, decoded, "
                                        "as fast as possible", (">=", 1.0)),
}
