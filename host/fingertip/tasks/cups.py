"""Cup counting and unstacking (the paper's Fig. 6): count rims by the nail's vibrations,
then lift a requested number of cups and separate them from the stack.

1. :func:`count_rims`: the nail slides down the outside of the stack (21 mm, over three
   rims) while the nail finger's contact microphone records; the paper's edge detector
   (:func:`~fingertip.events.vibration_onsets`: threshold, binarisation, temporal
   clustering) gives one onset per rim, and the arm's own z(t) log gives each onset's height
   (:func:`~fingertip.events.heights_at`).
2. :func:`unstack`: move to just below the target rim (half the measured rim pitch, or half
   the free wall below a thick lip, the grasping patch's middle there), close
   every finger to 0.5 N with the shared :class:`~.grip.Grip`, lift while holding, then let
   two opposite fingers alternately move up and down to shear the nested fit, so that the
   cup below the held ones drops back.

Only :class:`RobotHand` / :class:`RobotArm` and the sensor streams are used.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from ..events import heights_at, vibration_onsets
from .grip import Grip, PinchConfig, PinchResult
from .interfaces import RobotArm, RobotHand, require

log = logging.getLogger(__name__)


def _cup_grip() -> PinchConfig:
    return PinchConfig(0.5, step_mm=0.05, lift_mm=30.0, lift_speed_mm_s=20.0)


@dataclass
class CupConfig:
    slide_mm: float = 21.0
    """The paper: 21 mm, over three rims."""
    slide_speed_mm_s: float = 10.0
    nail_finger: str = "f0"
    k: float = 6.0
    """Detector threshold: the envelope's median + k robust standard deviations."""
    threshold: float | None = None
    """An absolute RMS threshold instead of ``k`` (the paper's tau)."""
    gap_s: float = 0.2
    """Bursts closer than this merge into one rim (must stay below pitch / speed)."""
    ride_mm: float | None = None
    """An onset less than this much of the slide's travel after the previous rim's is the
    same rim: a nail that rides over a thick rolled lip makes a burst where its lower edge
    meets the lip and others until its upper edge leaves it (the lip's and the nail's
    heights); must stay below the pitch. None: every merged burst is a rim."""
    tail_s: float = 0.15
    """Listening after the slide ends (the last rim's burst)."""
    grasp_below: float = 0.5
    """Grasp this fraction of the free wall below the target rim (0.5: mid-way)."""
    lip_mm: float = 0.0
    """How far the rim's lip reaches down from where the nail meets it: the free wall
    between two rims is ``pitch - lip_mm`` (0: a thin rim)."""
    patch_mm: float = 0.0
    """How far the grasping contact (the nail) reaches up from the nail's lower edge, the
    point that meets each rim first: the grasp puts the patch's middle on the wall's
    (0: a point)."""
    default_pitch_mm: float = 7.0
    """Pitch used when fewer than two rims were found."""
    grip: PinchConfig = field(default_factory=_cup_grip)
    strokes: int = 4
    """Separation strokes (each: two opposite fingers move in opposite directions)."""
    stroke_mm: float = 0.75
    """Each finger's vertical offset during a stroke (the pair moves 2 x this apart)."""
    stroke_frames: int = 8
    """Frames between strokes."""
    pair: tuple[str, str] = ("f0", "f2")


@dataclass
class RimCount:
    heights_mm: list[float]
    """Each detected rim's height (arm z at its onset), top first."""
    times_s: list[float]
    ok: bool = True
    detail: str = ""

    @property
    def count(self) -> int:
        return len(self.heights_mm)

    @property
    def pitch_mm(self) -> float | None:
        if self.count < 2:
            return None
        return float(np.median(-np.diff(self.heights_mm)))


@dataclass
class CupResult:
    target: int
    rims: RimCount
    grasp_z_mm: float | None = None
    grip: PinchResult | None = None
    strokes: int = 0
    failure: str | None = None
    """None, or why the recipe stopped: "sensor fault", "too few rims", or the grip's
    outcome ("timeout", "max force", ...)."""


def count_rims(hand: RobotHand, arm: RobotArm, cfg: CupConfig) -> RimCount:
    """Slide the nail down ``cfg.slide_mm`` from where the arm is; rims from vibrations."""
    require("counting rims", hand, arm, hand_methods=("read_audio",),
            arm_methods=("z_history",))
    blocks = [hand.read_audio(cfg.nail_finger)]       # starts (or flushes) the capture
    arm.slide_z(-cfg.slide_mm, cfg.slide_speed_mm_s)
    t_end = None
    while True:
        frames = hand.read()
        if frames is None:
            arm.stop()
            return RimCount([], [], False, "no frames during the slide")
        now = max(fr.host_time for fr in frames.values())
        if t_end is None and not arm.moving():
            t_end = now
        if t_end is not None and now - t_end >= cfg.tail_s:
            break
    blocks.append(hand.read_audio(cfg.nail_finger))
    audio = np.concatenate([b.samples for b in blocks])
    t0, fs = blocks[0].t0, blocks[-1].fs
    events = vibration_onsets(audio, fs, k=cfg.k, threshold=cfg.threshold, gap_s=cfg.gap_s,
                              t0=t0)
    if cfg.ride_mm is not None:
        ride_s, kept = cfg.ride_mm / cfg.slide_speed_mm_s, []
        for e in events:
            if not kept or e.time - kept[-1].time >= ride_s:
                kept.append(e)
        events = kept
    t, z = arm.z_history(t0)
    inside = [e for e in events if t[0] <= e.time <= t[-1]]
    if len(inside) < len(events):
        log.info("%d onset(s) outside the arm's log ignored", len(events) - len(inside))
    pairs = heights_at(inside, t, z)
    return RimCount([h for _, h in pairs], [e.time for e, _ in pairs])


def unstack(hand: RobotHand, arm: RobotArm, target: int, cfg: CupConfig | None = None,
            ) -> CupResult:
    """Count the rims from where the arm is (the nail just above the top rim), then lift
    ``target`` cups and separate them."""
    cfg = cfg or CupConfig()
    if not 1 <= target:
        raise ValueError("target must be 1 or more cups")
    require("unstacking cups", hand, arm, hand_methods=("read_audio", "step_z"),
            arm_methods=("z_history",))
    rims = count_rims(hand, arm, cfg)
    res = CupResult(target, rims)
    if not rims.ok:
        res.failure = "sensor fault"
        return res
    if rims.count < target:
        res.failure = "too few rims"
        return res
    pitch = rims.pitch_mm or cfg.default_pitch_mm
    x, y, _ = arm.position()
    res.grasp_z_mm = rims.heights_mm[target - 1] - cfg.lip_mm \
        - cfg.grasp_below * (pitch - cfg.lip_mm) - cfg.patch_mm / 2
    hand.open_fully()           # a nail moving back up would catch the lips from below
    arm.move_to(x, y, res.grasp_z_mm)
    grip = Grip(hand, cfg.grip, arm=arm)
    res.grip = grip.result
    if not grip.close():
        res.failure = grip.result.outcome.value
        return res
    arm.slide_z(cfg.grip.lift_mm, cfg.grip.lift_speed_mm_s)
    if not grip.hold(arm.moving):
        res.failure = grip.result.outcome.value
        return res
    a, b = cfg.pair
    frame = 0
    offset = 0.0

    def separate(_now: float) -> None:
        nonlocal frame, offset
        frame += 1
        if frame % cfg.stroke_frames or res.strokes >= cfg.strokes:
            return
        # Alternate: a up / b down, then a down / b up, ... (the pair moves 2 x stroke_mm).
        new = cfg.stroke_mm if res.strokes % 2 == 0 else -cfg.stroke_mm
        hand.step_z({a: new - offset, b: offset - new})
        offset = new
        res.strokes += 1

    if not grip.hold(lambda: res.strokes < cfg.strokes, separate):
        res.failure = grip.result.outcome.value
        return res
    hand.step_z({a: -offset, b: offset})                 # back level
    return res
