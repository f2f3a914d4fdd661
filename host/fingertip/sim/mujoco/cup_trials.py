"""The paper's cup counting and unstacking on the MuJoCo hand: ``tasks/cups.py`` unchanged.

Each trial (seed ``s``), drawn as today's world draws its own (``sim/world/cups.py``): the
rims' pitch (6.5-7.5 mm), each nested fit's cling (1.5-4 cup weights), how far each open
finger's nail reaches over the rims (0.2-0.6 mm: the hand's aperture set to the stack, as
the operator sets it), the start 2.5-4 mm above the top rim, the slide speed (6-15 mm/s), the
target (1-3 cups), and the nail finger's microphone: its gain (x0.6-1.5) and mains
(50/60 Hz). The hand tares above the stack, the arm puts the nails at the start, and
:func:`~fingertip.tasks.cups.unstack` counts the rims from the nail finger's piezo (f0)
and the arm's logged height, grasps, lifts and separates.

Success is judged from MuJoCo's ground truth, which the recipe never sees: the rims it
counted equal the rims the nail passed, and the cups lifted 10 mm or more at the end equal
the target.
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .experiment import failure_modes
from .cups import CUP_MASS, LIP_RADIUS, N_CUPS, cup_stack, lip_outer
from .attach import geometry
from .hand4 import FINGERS, nail_low_z, nail_radius_open
from .project import CupConfig, unstack
from .robot import HAND_UNIT, MujocoArm, MujocoHand, MujocoWorld, make_hand

log = logging.getLogger(__name__)

ARM_HOME_Z = 0.23
"""The palm's home height (m): the nails above the stack's top rim."""
LIFTED_MM = 10.0
GAP_S = 0.05
"""Bursts merge only across the fragments of one burst: the ride (``ride_mm``) joins a
rim's make and release, and at 15 mm/s the air between two lips lasts 0.1 s."""
GRASP_BELOW = 0.2
"""Of the free wall below the target rim: the onset comes 0.2-1.4 mm below the lip's top
(where the nail first touches the curved lip, and the envelope's rise), so the grasp aims
above the wall's middle."""


@dataclass
class CupTrial:
    """One trial's draws (see the module text)."""

    seed: int
    pitch_mm: float
    cling_n: list[float]
    overlap_mm: dict[str, float]
    above_mm: float
    speed_mm_s: float
    target: int
    preamp_gain: float = 1.0
    """Times the microphone's default gain."""
    mains_hz: float = 50.0

    @classmethod
    def draw(cls, seed: int) -> CupTrial:
        rng = np.random.default_rng(np.random.SeedSequence([seed, 0xC0B5]))
        pitch = float(rng.uniform(6.5, 7.5))
        cling = [float(rng.uniform(1.5, 4.0)) * CUP_MASS * 9.81 for _ in range(N_CUPS - 1)]
        overlap = {f: float(rng.uniform(0.2, 0.6)) for f in FINGERS}
        above = float(rng.uniform(2.5, 4.0))
        task = np.random.default_rng(np.random.SeedSequence([seed, 0x7A6]))
        target = int(task.integers(1, 4))
        speed = float(task.uniform(6.0, 15.0))
        # Drawn apart, so the stack and task draws stay those of earlier versions.
        mic = np.random.default_rng(np.random.SeedSequence([seed, 0xA0D10]))
        gain = float(mic.uniform(0.6, 1.5))
        mains = float(mic.choice([50.0, 60.0]))
        return cls(seed, pitch, cling, overlap, above, speed, target, gain, mains)


def hand_config(speed_mm_s: float) -> CupConfig:
    """The recipe's settings for this hand and these cups (the rest are its defaults): the
    nail meets a rim with its lower edge and rides over a lip 2.4 mm tall until its upper
    edge leaves it (3 mm higher), so one rim sounds over 5.4 mm of travel; the 3 mm nail
    goes mid-way on the free wall below the lip."""
    g = geometry()
    nail, lip = (g.nail_z[1] - g.nail_z[0]) * 1e3, 2 * LIP_RADIUS * 1e3
    return CupConfig(slide_speed_mm_s=speed_mm_s, gap_s=GAP_S, ride_mm=lip + nail, lip_mm=lip,
                     patch_mm=nail, grasp_below=GRASP_BELOW)


def set_up(tr: CupTrial) -> tuple[MujocoWorld, MujocoHand, MujocoArm]:
    """The trial's stack and hand, tared, the aperture set and the nails at the start."""
    scene = cup_stack(tr.pitch_mm * 1e-3, tr.cling_n, arm_z=ARM_HOME_Z)
    d = scene.data
    # The nails set to reach ``overlap`` over the rims' outer edge.
    start = {f: (nail_radius_open() - lip_outer()) * 1e3 + tr.overlap_mm[f] for f in FINGERS}
    seeds = {f: HAND_UNIT + k for k, f in enumerate(FINGERS)}
    levels = {f: "full" if f == "f0" else "strain" for f in FINGERS}
    world = MujocoWorld(scene, seeds, fidelity=levels)
    chain = world.sensors["f0"].piezo.chain
    chain.gain *= tr.preamp_gain
    chain.mains_hz = tr.mains_hz
    arm = MujocoArm(world)
    hand = make_hand(world, seeds)                  # tares above the stack, fully open
    hand.step(start)                                # the aperture set to the stack
    top = float(d.xpos[scene.info["cups"][0]][2]) + LIP_RADIUS
    arm.move_to(0.0, 0.0, (top + tr.above_mm * 1e-3 - nail_at_arm_zero()) * 1e3)
    return world, hand, arm


def nail_at_arm_zero() -> float:
    """The nail's lower edge above the table with the arm at z = 0 (m)."""
    return ARM_HOME_Z - nail_low_z()


def cup_trial(seed: int, cfg: CupConfig | None = None) -> dict:
    """One trial; the result as ``sim/experiment.py`` records today's world's."""
    tr = CupTrial.draw(seed)
    world, hand, arm = set_up(tr)
    scene, d = world.scene, world.d
    cups = scene.info["cups"]
    nail0 = nail_at_arm_zero()
    z0 = np.array([d.xpos[c][2] for c in cups])
    lips = z0 + LIP_RADIUS                          # each rim's top (m)
    z_start = nail0 + arm.position()[2] * 1e-3
    cfg = cfg or hand_config(tr.speed_mm_s)
    r = unstack(hand, arm, tr.target, cfg)
    passed = int(np.sum((lips < z_start) & (lips > z_start - cfg.slide_mm * 1e-3)))
    counted = r.rims.count == passed
    rise = (np.array([d.xpos[c][2] for c in cups]) - z0) * 1e3
    lifted = int(np.sum(rise >= LIFTED_MM))
    fits = scene.info["fits"]
    clinging = lifted > tr.target
    failure = r.failure
    if failure is None:
        if not counted:
            failure = "miscounted"
        elif clinging:
            failure = "not separated"
        elif lifted != tr.target:
            failure = "wrong number lifted"
    elif failure == "too few rims" and not counted:
        failure = "miscounted (too few rims)"
    truth_arm = (lips - nail0) * 1e3                # rims' tops in arm z (mm)
    err = [float(np.min(np.abs(truth_arm - h))) for h in r.rims.heights_mm]
    return {"seed": seed, "target": tr.target, "speed_mm_s": round(tr.speed_mm_s, 3),
            "pitch_mm": round(tr.pitch_mm, 3), "rims_found": r.rims.count,
            "rims_passed": passed, "counted": counted,
            "rim_height_error_mm": round(max(err), 3) if err else None,
            "grasp_z_mm": r.grasp_z_mm, "lifted": lifted, "lifted_ok": lifted == tr.target,
            "strokes": r.strokes, "fits_let_go": sum(fits.broken),
            "success": failure is None, "failure": failure,
            "rise_mm": [round(float(v), 2) for v in rise]}


@dataclass
class CupRun:
    seed: int
    trials: list[dict] = field(default_factory=list)

    def summary(self) -> dict:
        return {"world": "mujoco", "trials": len(self.trials),
                "counted": sum(t["counted"] for t in self.trials),
                "lifted": sum(t["lifted_ok"] for t in self.trials),
                "success": self.success, "failure_modes": failure_modes(self.trials)}

    @property
    def success(self) -> int:
        return sum(t["success"] for t in self.trials)


def run_cups(trials: int = 36, seed: int = 0,
             progress: Callable[[str], None] | None = None) -> CupRun:
    """The paper's 36 cup trials (five cups, a 21 mm slide over three rims, 1-3 cups)."""
    out = CupRun(seed)
    for s in range(seed, seed + trials):
        out.trials.append(cup_trial(s))
        if progress is not None:
            progress(f"cups seed {s}: {out.trials[-1]['failure'] or 'ok'}")
    return out
