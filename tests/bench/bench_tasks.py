"""The paper's manipulation protocols on the simulated hand (fingertip.sim.experiment):
pinch 25 + 25, cups 36, shake-and-pick 56, seeds from 0, and the pinch loop's latency.
"""
from __future__ import annotations

import os
import tempfile

import numpy as np

from fingertip.sim import experiment as ex


_last: list = []
"""The latest run's results, for :func:`tables`."""


def run() -> dict[str, float]:
    os.environ.setdefault("FINGERTIP_TASKS_CACHE",
                          os.path.join(tempfile.gettempdir(), "fingertip-tasks-models"))
    pinches = [ex.run_pinch(o, 25, 0) for o in ("tofu", "chip")]
    cups = ex.run_cups(36, 0)
    shake = ex.run_shake(56, 0)
    lat = np.concatenate([p.latencies_ms for p in pinches])
    _last[:] = [pinches, cups, shake]
    return {
        "pinch_success": sum(p.success for p in pinches),
        "cups_success": cups.success,
        "shake_pick_success": shake.success,
        "pinch_loop_latency_ms": round(float(np.percentile(lat, 99)), 4),
    }


def tables(figures: dict) -> dict[str, str]:
    if not _last:
        return {}
    pinches, cups, shake = _last
    return {"Tasks: pinch (25 trials per object)": ex.pinch_table(pinches),
            "Tasks: cup counting and unstacking (36 trials)": ex.cups_table(cups),
            "Tasks: shake-and-pick (56 trials)": ex.shake_table(shake)}


DESCRIPTION = {
    "pinch_success": ("pinch trials held, lifted 20 mm and unbroken, of 50 (25 tofu at 0.5 N, "
                      "25 chip at 0.1 N; the paper: 25/25 each)", (">=", 50)),
    "cups_success": ("cup trials counted correctly and lifting the requested 1-3 cups, of 36 "
                     "(the paper: 36/36)", (">=", 36)),
    "shake_pick_success": ("shake-and-pick trials opening the box with the requested "
                           "material, of 56 (the paper: 53/56)", (">=", 53)),
    "pinch_loop_latency_ms": ("pinch controller's work per frame, frame arrival to command, "
                              "p99 over all 50 trials (the paper's loop: 15 Hz on a CPU)",
                              ("<", 5.0)),
}
