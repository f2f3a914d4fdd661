"""Cost of the simulation: simulated seconds per wall second, per scene.

``make bench`` calls :func:`scene_realtime_factors` (keys ``sim_realtime_factor_<scene>``).
Nothing here asserts a timing; the figures are measured on whatever machine runs them.
"""
from __future__ import annotations

import time
from collections.abc import Callable

from fingertip.sim.physics import (
    BoxShake,
    ContactMakeBreak,
    CupStackSlide,
    Press,
    Scene,
    Slide,
    simulate,
)

STANDARD_SCENES: dict[str, Callable[[], Scene]] = {
    "press": lambda: Press(angle_deg=20, height_mm=2, peak_n=5.0),
    "slide": lambda: Slide("coarse_fabric", speed_mm_s=20, normal_n=1.0, duration=5.0),
    "contact": lambda: ContactMakeBreak(repeats=3),
    "cups": lambda: CupStackSlide(),
    "shake": lambda: BoxShake("screws"),
}
"""The paper's scenes at their paper durations (slide: 5 s)."""


def realtime_factor(scene: Scene, *, repeats: int = 3, seed: int = 0) -> float:
    """Median over ``repeats`` runs of simulated seconds / wall seconds (whole simulate call,
    including set-up)."""
    factors = []
    for k in range(repeats):
        w0 = time.perf_counter()
        res = simulate(scene, seed=seed + k)
        wall = time.perf_counter() - w0
        factors.append(res.duration_s / wall if wall > 0 else float("inf"))
    factors.sort()
    return factors[len(factors) // 2]


def scene_realtime_factors(repeats: int = 3) -> dict[str, float]:
    """``{"sim_realtime_factor_<name>": factor}`` for each of :data:`STANDARD_SCENES`."""
    simulate(Press(ramp_s=0.1, hold_s=0, pre_s=0, post_s=0.1))  # warm imports and caches
    return {f"sim_realtime_factor_{name}": round(realtime_factor(make(), repeats=repeats), 2)
            for name, make in STANDARD_SCENES.items()}
