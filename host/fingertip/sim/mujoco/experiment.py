"""The paper's pinch on the MuJoCo gripper: the recipe of ``tasks/pinch.py`` unchanged.

Each trial (seed ``s``): the tofu or the chip placed off-centre by up to 1 mm, the arm
brings the fingertips' lower 5 mm beside the object's top, each finger starts 0.3-1.3 mm
from the object's face (as the virtual world's trials do), the hand tares, then ``pinch``
closes to F_th and lifts 20 mm. F_th is the virtual world's demonstration at the paper's
firmness (``sim/experiment.py``), so both worlds run the same controller. Success is judged
from MuJoCo's ground truth, which the recipe never sees: not broken, and both halves of the
object lifted by at least 90 % of the lift.
"""
from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ._require import mujoco
from .gripper import gripper
from .project import CHIP, TOFU, PinchConfig, demonstrate, pinch
from .robot import HAND_UNIT, MujocoArm, MujocoHand, MujocoWorld, open_gap_mm

log = logging.getLogger(__name__)

OBJECTS = {"tofu": (TOFU, 0.5, 0.05, 0.015, 0.025),
           "chip": (CHIP, 0.1, 0.005, 0.001, 0.034)}
"""Object -> (spec, the paper's firmness (N), closing step (mm), half width (m), top (m))."""
DEMO_SEED_OFFSET = 100_000
ARM_DOWN_MM = -100.0 + 4.0
"""From home, the fingertips' roof 6 mm below the top of a 25 mm object."""


@dataclass
class PinchRun:
    object: str
    f_th_n: float
    seed: int
    trials: list[dict] = field(default_factory=list)

    @property
    def success(self) -> int:
        return sum(t["success"] for t in self.trials)

    def summary(self) -> dict:
        return {"object": self.object, "world": "mujoco", "f_th_n": self.f_th_n,
                "trials": len(self.trials), "success": self.success,
                "broken": sum(t["broken"] for t in self.trials),
                "dropped": sum(t["dropped"] for t in self.trials),
                "failure_modes": failure_modes(self.trials)}


def failure_modes(trials: list[dict]) -> dict[str, int]:
    """How many trials failed in each way (by their ``failure``), none dropped."""
    return dict(Counter(t["failure"] for t in trials if t["failure"]))


def _place(world: MujocoWorld, name: str, dy: float) -> None:
    mj = mujoco()
    m, d = world.m, world.d
    for half in "ab":
        body = mj.mj_name2id(m, mj.mjtObj.mjOBJ_BODY, f"{name}_{half}")
        d.qpos[m.jnt_qposadr[m.body_jntadr[body]] + 1] += dy
    mj.mj_forward(m, d)


def _heights(world: MujocoWorld, name: str) -> np.ndarray:
    m = world.m
    return np.array([world.d.xpos[m.body(f"{name}_{h}").id][2] for h in "ab"])


def pinch_trial(name: str, f_th_n: float, seed: int) -> dict:
    """One trial; the result as ``sim/experiment.py`` records it."""
    spec, _, step, half_width, top = OBJECTS[name]
    rng = np.random.default_rng(np.random.SeedSequence([seed, 30]))
    dy = float(rng.uniform(-1.0, 1.0)) * 1e-3
    gap = open_gap_mm(half_width)
    start = {"left": gap - dy * 1e3 - float(rng.uniform(0.3, 1.3)),
             "right": gap + dy * 1e3 - float(rng.uniform(0.3, 1.3))}
    seeds = {"left": HAND_UNIT, "right": HAND_UNIT + 1}
    scene = gripper((name,))
    world = MujocoWorld(scene, seeds, start_mm=start)
    _place(world, name, dy)
    arm = MujocoArm(world)
    arm.move_to(0.0, 0.0, ARM_DOWN_MM + (top - 0.025) * 1e3)
    hand = MujocoHand(world, seeds)
    z0 = _heights(world, name)
    cfg = PinchConfig(f_th_n, step_mm=step)
    r = pinch(hand, arm, cfg)
    broken = world.breakables.broken[name]
    lifted = float((_heights(world, name) - z0).min() * 1e3)
    dropped = r.ok and not broken and lifted < 0.9 * cfg.lift_mm
    failure = None if r.ok else r.outcome.value
    if failure is None and broken:
        failure = "broken"
    elif failure is None and dropped:
        failure = "dropped"
    return {"seed": seed, "success": failure is None, "outcome": r.outcome.value,
            "broken": broken, "dropped": dropped, "failure": failure,
            "lifted_mm": lifted, "detail": r.detail}


def run_pinch(name: str = "tofu", trials: int = 25, seed: int = 0,
              f_th_n: float | None = None,
              progress: Callable[[str], None] | None = None) -> PinchRun:
    """The paper's pinch protocol, ``trials`` trials from ``seed``."""
    spec, firmness, step, _, _ = OBJECTS[name]
    if f_th_n is None:
        f_th_n = demonstrate(spec, firmness, seed=seed + DEMO_SEED_OFFSET, step_mm=step).f_th_n
    out = PinchRun(name, f_th_n, seed)
    for s in range(seed, seed + trials):
        out.trials.append(pinch_trial(name, f_th_n, s))
        if progress is not None:
            progress(f"{name} seed {s}: {out.trials[-1]['failure'] or 'ok'}")
    return out
