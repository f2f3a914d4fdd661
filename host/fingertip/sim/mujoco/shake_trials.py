"""The paper's shake-and-pick on the MuJoCo hand: ``tasks/shake_pick.py`` unchanged.

Each trial (seed ``s``) takes today's world's draws for the same seed
(:func:`~fingertip.sim.world.boxes.make_box_world`): which box holds what, how many items
(screws 5-12, rubber bands 6-14), each finger's start gap from the first box's face
(0.3-1.3 mm; both MuJoCo boxes stand square under the hand), the microphone's gain (x0.6-1.5)
and mains (50/60 Hz). The contents are free bodies in closed boxes (:mod:`.boxes`); what the
nail finger ``f0`` hears of them is their contacts with the walls (:mod:`.box_sound`). The
arm's real shake is what its servos make of the command (the world draws 0.8-1.05 of it).

The hand tares above the boxes, fully open; the recipe then grips, lifts, shakes, puts back
each box and pushes the chosen box's tray with ``f1``. The arm goes up to ``TRAVEL_Z_MM``
between boxes (the world's arm jumps). Success is judged from MuJoCo's ground truth, which
the recipe never sees: the target's tray slid out ``TRAY_OPEN_MM`` or more, the other's not.
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .box_sound import BoxSound
from .boxes import BOX_X, HALF, BoxFill, box_pair
from .experiment import failure_modes
from .hand4 import FINGERS, nail_low_z, nail_radius_open
from .project import ShakeConfig, VibrationClassifier, make_box_world, shake_and_pick, \
    shake_model_path
from .robot import HAND_UNIT, MujocoWorld, MujocoArm, make_hand

log = logging.getLogger(__name__)

ARM_HOME_Z = 0.2
GRIP_NAIL_Z = 0.030
"""The nails' lower edge above the table while gripping a box (m): above its centre of mass
(20-22 mm; contents on the floor lower it), so that the box hangs from the line between the
nails instead of balancing on it. Gripped at 12 mm, 8 mm under it, a box whose screws rolled
to one end toppled about that line to 20-25 degrees (docs/mujoco.md)."""
GRIP_Z_MM = (GRIP_NAIL_Z - (ARM_HOME_Z - nail_low_z())) * 1e3
TRAVEL_Z_MM = (0.081 - (ARM_HOME_Z - nail_low_z())) * 1e3
"""Between places the nails' lower edge passes 81 mm above the table, 37 mm above the boxes'
roofs."""
ARM_SPEED_MM_S = 100.0
"""The arm's moves between places (its shake is the recipe's)."""
STRAIGHT_MM = 15.0
"""The arm steps aside (the recipe's ``clear_mm``) without rising."""
CLEAR_MM = (0.0, 7.0)
"""The recipe's ``clear_mm``: the pusher ``f1`` stands at +y, 0.3-1.3 mm from the tray's end;
a box put back lands up to 5 mm from where it stood (docs/mujoco.md), and ``f3`` at -y has
14.5 mm."""
TRAY_OPEN_MM = 6.0
"""As today's world's ``tray_open_mm``."""
MATERIALS = ("screws", "rubber_bands")
OPEN_NAIL_Z = 0.012
"""Opening, the nails' lower edge is this high (m): gripped at ``GRIP_NAIL_Z`` the pusher's
fingertip met the sleeve's roof when the tray had gone 4 mm (the recipe's ``open_dz_mm``)."""


PUSH_MM = 9.0


def hand_config() -> ShakeConfig:
    """The recipe's settings for this hand (the rest its defaults): the pusher goes 9 mm past
    its touch instead of 8, as the finger's position servo lags its command by 1.8 mm at the
    push's 20 mm/s (0.25 mm per 80 Hz frame) against the tray's 0.3 N: the tray then slides
    out about 8 mm (the world's fingers have no lag); ``clear_mm`` (``CLEAR_MM``) and
    ``open_dz_mm`` (``OPEN_NAIL_Z``), below."""
    return ShakeConfig(push_mm=PUSH_MM, clear_mm=CLEAR_MM,
                       open_dz_mm=(OPEN_NAIL_Z - GRIP_NAIL_Z) * 1e3)


@dataclass
class ShakeTrial:
    seed: int
    fills: tuple[BoxFill, BoxFill]
    gaps_mm: dict[str, float]
    preamp_gain: float
    mains_hz: float

    @classmethod
    def draw(cls, seed: int) -> ShakeTrial:
        world, _, _ = make_box_world(seed)
        fills = tuple(BoxFill(b.content, b.items) for b in world.boxes)
        return cls(seed, fills, dict(world.boxes[0].gaps_mm),  # type: ignore[arg-type]
                   float(world.chain_options["preamp_gain"]),
                   float(world.chain_options["mains_hz"]))


def set_up(tr: ShakeTrial, default_chain: bool = False):
    """The trial's boxes, the hand (tared, open at its start gaps), the arm and the sound
    (``default_chain``: the microphone's default gain and mains, not the trial's)."""
    scene = box_pair(tr.fills, tr.seed, arm_z=ARM_HOME_Z)
    reach = nail_radius_open() * 1e3
    start = {"f0": reach - HALF[0] * 1e3 - tr.gaps_mm["f0"],
             "f2": reach - HALF[0] * 1e3 - tr.gaps_mm["f2"],
             "f1": reach - HALF[1] * 1e3 - tr.gaps_mm["f1"], "f3": 0.0}
    seeds = {f: HAND_UNIT + k for k, f in enumerate(FINGERS)}
    levels = {f: "full" if f == "f0" else "strain" for f in FINGERS}
    world = MujocoWorld(scene, seeds, fidelity=levels, start_mm=start)
    if not default_chain:
        chain = world.sensors["f0"].piezo.chain
        chain.gain, chain.mains_hz = tr.preamp_gain, tr.mains_hz
    sound = BoxSound(world.m, world.d, scene.info["boxes"], world.sensors["f0"], tr.seed)
    world.updates.append(sound.update)
    arm = MujocoArm(world, travel_z_mm=TRAVEL_Z_MM, speed_mm_s=ARM_SPEED_MM_S,
                    straight_mm=STRAIGHT_MM)
    hand = make_hand(world, seeds)
    return world, hand, arm, sound


def shake_trial(seed: int, target: str, clf, cfg: ShakeConfig | None = None,
                also=None) -> dict:
    """One trial with the classifier ``clf``; the result as ``sim/experiment.py`` records
    today's world's. ``also``: another classifier that votes on the same shakes (offline,
    the same 10 Hz windows), recorded beside the recipe's votes (``also_vote``)."""
    from .shake_model import RecordingHand, ShakeMarkingArm, vote

    tr = ShakeTrial.draw(seed)
    world, hand, arm, sound = set_up(tr)
    boxes = world.scene.info["boxes"]
    x_log: list[float] = []
    world.updates.append(lambda d: x_log.append(float(d.qpos[0])))
    cfg = cfg or hand_config()
    rec = RecordingHand(hand)
    start = [world.d.xpos[b["body"]].copy() for b in boxes]
    try:
        r = shake_and_pick(rec, ShakeMarkingArm(arm, rec), clf,
                           [(x * 1e3, 0.0, GRIP_Z_MM) for x in BOX_X], target, cfg)
    except RuntimeError as e:
        # The arm stopped on something (a robot's collision stop): a failed trial.
        moved = [round(float(np.linalg.norm(world.d.xpos[b["body"]] - p0)) * 1e3, 2)
                 for b, p0 in zip(boxes, start, strict=True)]
        log.info("seed %d: %s (boxes moved %s mm)", seed, e, moved)
        return {"seed": seed, "target": target,
                "boxes": [{"content": f.content, "items": f.items, "vote": None,
                           "predictions": 0, "shares": {}, "moved_mm": m}
                          for f, m in zip(tr.fills, moved, strict=True)],
                "opened": None, "success": False, "failure": "arm blocked",
                "detail": str(e)}
    trays = [float(world.d.qpos[b["tray_qpos"]] * 1e3) for b in boxes]
    opened = [i for i, t in enumerate(trays) if t >= TRAY_OPEN_MM]
    want = [i for i, f in enumerate(tr.fills) if f.content == target]
    failure = r.failure
    if failure is None and opened != want:
        failure = "wrong vote" if r.chosen is not None and r.chosen != want[0] else "not opened"
    out_boxes = []
    for k, (f, b, b_info) in enumerate(zip(tr.fills, sound.boxes, boxes, strict=True)):
        rd = r.readings[k] if k < len(r.readings) else None
        row = {"content": f.content, "items": f.items, "vote": rd.vote if rd else None,
               "predictions": rd.predictions if rd else 0,
               "shares": {c: round(v, 3) for c, v in rd.shares.items()} if rd else {},
               "impacts": b.impacts, "ticks": b.ticks, "tray_mm": round(trays[k], 2)}
        if also is not None and k < len(rec.shakes):
            v, shares = vote(also, rec.audio(k, cfg.listen), cfg.step_s)
            row["also_vote"] = v
            row["also_shares"] = {c: round(x, 3) for c, x in shares.items()}
        row["moved_mm"] = round(float(np.linalg.norm(world.d.xpos[b_info["body"]]
                                                     - start[k])) * 1e3, 2)
        out_boxes.append(row)
    x = np.asarray(x_log)
    return {"seed": seed, "target": target, "boxes": out_boxes,
            "opened": opened[0] if len(opened) == 1 else None,
            "shake_amplitude_mm": round(float(np.ptp(x)) * 500, 2) if len(x) else None,
            "preamp_gain": round(tr.preamp_gain, 3), "mains_hz": tr.mains_hz,
            "success": failure is None, "failure": failure}


@dataclass
class ShakeRun:
    seed: int
    trials: list[dict] = field(default_factory=list)

    @property
    def success(self) -> int:
        return sum(t["success"] for t in self.trials)

    def summary(self) -> dict:
        votes = [b for t in self.trials for b in t["boxes"] if b["vote"] is not None]
        return {"world": "mujoco", "trials": len(self.trials), "success": self.success,
                "box_votes_correct": sum(b["vote"] == b["content"] for b in votes),
                "box_votes": len(votes), "failure_modes": failure_modes(self.trials)}


def targets(trials: int, seed: int) -> list[str]:
    """The targets in random order within each pair of trials (today's world's draw)."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x5EA]))
    out: list[str] = []
    while len(out) < trials:
        out += [str(m) for m in rng.permutation(MATERIALS)]
    return out[:trials]


def classifiers(model: str = "mujoco"):
    """The recipe's shake classifier (``mujoco``: trained on MuJoCo shakes; ``world``: today's
    world's) and the other one."""
    from .shake_model import mujoco_shake_model_path

    mine = VibrationClassifier(mujoco_shake_model_path(), kind="shake")
    world = VibrationClassifier(shake_model_path(), kind="shake")
    if model not in ("mujoco", "world"):
        raise ValueError(f"model must be 'mujoco' or 'world', not {model!r}")
    return (mine, world) if model == "mujoco" else (world, mine)


def run_shake(trials: int = 56, seed: int = 0, cfg: ShakeConfig | None = None,
              progress: Callable[[str], None] | None = None, model: str = "mujoco") -> ShakeRun:
    """The paper's 56 shake-and-pick trials, the recipe with the classifier ``model``; the
    other one votes on the same shakes beside it."""
    clf, also = classifiers(model)
    out = ShakeRun(seed)
    for s, target in zip(range(seed, seed + trials), targets(trials, seed), strict=True):
        out.trials.append(shake_trial(s, target, clf, cfg, also))
        if progress is not None:
            progress(f"shake seed {s}: {out.trials[-1]['failure'] or 'ok'}")
    return out
