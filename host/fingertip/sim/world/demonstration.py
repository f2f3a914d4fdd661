"""The pinch's demonstration in the simulated world: a teleoperator grasps and lifts the
object once, as firmly as it needs, while the fingertips record what they feel.

The paper calibrates each object's grip force from one demonstration: an operator
teleoperates the hand to grasp and lift the object without damage, and the recorded pinch
force becomes ``F_th``. Here the operator stands in for a person watching the object, so it
closes each finger until the *true* contact force reaches the firmness it chose; the
recording holds only the fingertips' own estimates (baseline-corrected force magnitudes, one
row per frame), which :func:`~.pinch.demonstrate_threshold` turns into ``F_th``. The
estimate therefore carries every sensor error of the virtual fingertips.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...tasks.grip import force_vectors
from ...tasks.pinch import demonstrate_threshold
from .hand import ObjectSpec, make_world


@dataclass
class Demonstration:
    object: str
    firmness_n: float
    """The true contact force per finger the operator held."""
    rows: list[dict[str, float]]
    """Per frame, each finger's estimated force magnitude (baseline removed), in newtons."""
    f_th_n: float
    """The threshold the demonstration gives (:func:`demonstrate_threshold`)."""
    broken: bool


def demonstrate(spec: ObjectSpec, firmness_n: float, *, seed: int, step_mm: float,
                lift_mm: float = 20.0, lift_speed_mm_s: float = 20.0,
                baseline_frames: int = 8, max_frames: int = 4000) -> Demonstration:
    """One teleoperated pinch-and-lift of ``spec`` at ``firmness_n`` per finger (seeded
    placement as in the trials, seed ``seed``); returns the recording and its ``F_th``."""
    if not 0 < firmness_n < spec.crush_n:
        raise ValueError(f"firmness {firmness_n} N must be above 0 and below the object's "
                         f"crush force {spec.crush_n} N")
    world, hand, arm = make_world(spec, seed)
    fingers = list(hand.fingers)

    def read() -> dict[str, tuple[float, float]]:
        frames = hand.read(0.5)
        if frames is None:
            raise RuntimeError("the simulated hand sent no frames during the demonstration")
        return force_vectors(hand, frames, fingers)

    base = [read() for _ in range(baseline_frames)]
    # The estimate at rest is zeroed as a vector, as the grip does (grip.Grip.close).
    baseline = {f: np.mean([r[f] for r in base], axis=0) for f in fingers}
    rows: list[dict[str, float]] = []
    lifting = False
    for _ in range(max_frames):
        vecs = read()
        rows.append({f: math.hypot(vecs[f][0] - baseline[f][0], vecs[f][1] - baseline[f][1])
                     for f in fingers})
        true = world.contact_forces()
        closing = {f: step_mm for f in fingers if true[f] < firmness_n}
        if closing:
            hand.step(closing)
        elif not lifting:
            arm.slide_z(lift_mm, lift_speed_mm_s)
            lifting = True
        elif not arm.moving():
            break
    else:
        raise RuntimeError(f"the demonstration did not finish in {max_frames} frames")
    hand.open_fully()
    return Demonstration(spec.name, firmness_n, rows, demonstrate_threshold(rows),
                         world.obj.broken)
