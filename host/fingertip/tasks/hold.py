"""Hold an object and keep it: raise the grip force when it starts to slip.

:func:`hold` keeps each finger's normal force at a target (closing a finger whose force is
below it, proportionally, at most ``max_step_mm`` per frame: the rate the hand allows) and
reacts to each ``slip_onset`` of a :class:`~fingertip.events.slip.SlipDetector` (piezo bursts
and the force ratio, or the force ratio alone). Without a reflex (``reflex="none"``) it only
keeps the initial force, as the paper's hold does. Two laws (``law``):

- ``"coulomb"`` (default): the grip Coulomb friction needs for the load the hold is rated
  for. While the object sticks, the fingers' tangential forces add up to the load it hangs
  with (W0, smoothed); at a slip onset the contact is at its friction limit, so the pooled
  ratio sum |F_t| / sum F_n there (the largest over the onset frame and the next
  ``mu_frames``) estimates mu. A sudden load is not seen in F_t while the object slides
  (kinetic friction caps it at mu_k F_n), so the law does not wait for it: each finger's
  target becomes ``safety`` x W_design / (fingers x mu_est), W_design = W0 x (1 + k x
  ``rated_load``) after the k-th slip onset (each further slip shows the load exceeds the
  last design), reached at the hand's full rate; a target never falls below the force held.
- ``"proportional"`` (the earlier law, kept for comparison): every target rises by
  ``raise_fraction`` at a slip onset, then each finger is kept at or above its tangential
  force / (``ratio_margin`` x the largest ratio seen since the first slip).

Each fingertip's force estimate is split into its normal part (along ``normal_deg``, the
direction in the fingertip's frame in which this finger presses: the hand's geometry) and
its tangential part (perpendicular to it, in the sensing plane: the fingertip must be
mounted so that the object's weight pulls across its prism, not along it).
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from ..events.reflex import ReflexEvent
from ..events.slip import SlipConfig, SlipDetector
from .grip import SensorFault
from .interfaces import RobotHand


@dataclass
class HoldConfig:
    normal_deg: Mapping[str, float]
    """Per finger: the direction of its normal force in its fingertip's (fx, fy) frame."""
    reflex: str = "fused"
    """fused (piezo + force ratio), force (force ratio only) or none."""
    law: str = "coulomb"
    """coulomb or proportional (see the module text)."""
    safety: float = 1.25
    """Coulomb law: the margin on friction (mu scatters between surfaces and with the force
    estimates' error), as in a gripper's design rule F_n >= S x F_t / mu."""
    rated_load: float = 1.0
    """Coulomb law: the added load, as a fraction of the load held before the slip, that one
    reflex is designed to carry (1: the weight may double). A user hanging more sets more."""
    mu_frames: int = 2
    """Coulomb law: frames after the onset frame over which the friction ratio is read."""
    raise_fraction: float = 0.5
    """Proportional law: at a slip onset every target rises at once by this fraction (the
    force ratio at that
    moment is not yet known) ..."""
    ratio_margin: float = 0.7
    """... and from then on each finger's normal force is kept at or above its tangential
    force / (ratio_margin x mu), mu being the largest tangential/normal ratio seen since the
    first slip (a slipping contact shows its friction coefficient; static friction is a
    little above it, so holding at 70 % of it stops a slide and keeps the object)."""
    max_force_n: float = 12.0
    stiffness_n_per_mm: float = 1.0
    """Of the object under a fingertip (from the grip's closing: force per mm of travel)."""
    max_step_mm: float = 0.5
    """Per frame: the fingers' speed limit (0.5 mm at 80 Hz = 40 mm/s)."""
    finger_speed_mm_s: float = 40.0
    deadband: float = 0.15
    """Do not move for errors below this fraction of the target: a force estimate scatters
    by several percent from frame to frame, and every move makes motor noise that the
    piezos must be gated against."""
    smooth: float = 0.3
    """Weight of the newest frame in the force the regulation sees."""
    gate_margin_s: float = 0.03
    """The piezos are gated for a move's duration plus this."""
    read_timeout_s: float = 0.5
    slip: SlipConfig = field(default_factory=SlipConfig)


@dataclass
class HoldResult:
    ok: bool = True
    detail: str = ""
    frames: int = 0
    slip_events: list[ReflexEvent] = field(default_factory=list)
    grip_n: list[float] = field(default_factory=list)
    """Mean normal force over the fingers, per frame."""

    @property
    def mean_grip_n(self) -> float:
        return float(np.mean(self.grip_n)) if self.grip_n else 0.0


def split_force(fx: float, fy: float, normal_deg: float) -> tuple[float, float]:
    """(normal, tangential) parts of a fingertip force for a normal direction."""
    a = math.radians(normal_deg)
    return fx * math.cos(a) + fy * math.sin(a), -fx * math.sin(a) + fy * math.cos(a)


class CoulombLaw:
    """The Coulomb law's state over frames (see the module text): the load held while the
    object sticks, the friction ratio at slip onsets and the per-finger force needed."""

    def __init__(self, fingers: int, safety: float, rated_load: float, mu_frames: int,
                 smooth: float) -> None:
        self.fingers, self.safety, self.rated_load = fingers, safety, rated_load
        self.mu_frames, self.smooth = mu_frames, smooth
        self.load_n: float | None = None
        """W0: sum of |F_t| while sticking (smoothed), frozen at the first slip."""
        self.mu_est: float | None = None
        self.slips = 0
        self.need_n: float | None = None
        self._window = 0

    def frame(self, normal: Mapping[str, float], tang: Mapping[str, float],
              slip: bool) -> None:
        ft = sum(abs(t) for t in tang.values())
        fn = sum(normal.values())
        if self.slips == 0 and not slip:
            self.load_n = ft if self.load_n is None else \
                self.load_n + self.smooth * (ft - self.load_n)
        if slip:
            self.slips += 1
            self._window = self.mu_frames + 1
            if self.load_n is None:          # slipping from the first frame: take it now
                self.load_n = ft
        if self._window > 0 and fn > 0:
            # At the friction limit the pooled ratio is mu (pooling averages the fingers'
            # tangential errors, which have opposite signs as often as not).
            r = ft / fn
            self.mu_est = r if self.mu_est is None else max(self.mu_est, r)
            self._window -= 1
        if self.slips and self.mu_est and self.load_n is not None:
            design = self.load_n * (1 + self.slips * self.rated_load)
            self.need_n = self.safety * design / (self.fingers * self.mu_est)


def hold(hand: RobotHand, cfg: HoldConfig, running: Callable[[], bool]) -> HoldResult:
    """Hold while ``running()`` is true (checked once per frame)."""
    if cfg.reflex not in ("fused", "force", "none"):
        raise ValueError(f"reflex must be fused, force or none, not {cfg.reflex!r}")
    if cfg.law not in ("coulomb", "proportional"):
        raise ValueError(f"law must be coulomb or proportional, not {cfg.law!r}")
    if cfg.safety < 1 or cfg.rated_load < 0 or cfg.mu_frames < 0:
        raise ValueError("safety must be >= 1, rated_load >= 0 and mu_frames >= 0")
    fingers = list(cfg.normal_deg)
    res = HoldResult()
    det = None
    if cfg.reflex != "none":
        fs = hand.read_audio(fingers[0]).fs if cfg.reflex == "fused" else 44100.0
        det = SlipDetector(fingers, fs, cfg.slip, mode=cfg.reflex)
        if cfg.reflex == "fused":
            for f in fingers[1:]:
                hand.read_audio(f)              # start every finger's capture now
    target: dict[str, float] = {}
    level: dict[str, float] = {}
    mu: float | None = None
    law = CoulombLaw(len(fingers), cfg.safety, cfg.rated_load, cfg.mu_frames, cfg.smooth)
    while True:
        frames = hand.read(cfg.read_timeout_s)
        if frames is None:
            res.ok, res.detail = False, "no frames"
            return res
        res.frames += 1
        now = max(fr.host_time for fr in frames.values())
        normal: dict[str, float] = {}
        tang: dict[str, float] = {}
        new: list[ReflexEvent] = []
        try:
            for f in fingers:
                fr = frames.get(f)
                if fr is None or not fr.ok:
                    raise SensorFault(f"finger {f}: missing or flagged frame")
                est = hand.force_model(f).estimate_frame(fr)
                n, t = split_force(float(est.fx), float(est.fy), cfg.normal_deg[f])
                if not (math.isfinite(n) and math.isfinite(t)):
                    raise SensorFault(f"finger {f}: non-finite force")
                normal[f] = n
                tang[f] = t
                if det is not None:
                    new += det.feed_force(f, fr.host_time, n, t)
        except SensorFault as e:
            hand.open_fully()
            res.ok, res.detail = False, str(e)
            return res
        if det is not None and cfg.reflex == "fused":
            for f in fingers:
                blk = hand.read_audio(f)
                new += det.feed_audio(f, blk.samples, blk.t0)
        for f in fingers:
            target.setdefault(f, normal[f])
            level[f] = normal[f] if f not in level else \
                level[f] + cfg.smooth * (normal[f] - level[f])
        res.slip_events += new
        if cfg.law == "coulomb":
            law.frame(normal, tang, bool(new))
            if law.need_n is not None:
                for f in fingers:
                    target[f] = min(cfg.max_force_n, max(target[f], law.need_n))
        elif new:
            for f in fingers:
                target[f] = min(cfg.max_force_n,
                                max(target[f], level[f]) * (1 + cfg.raise_fraction))
        if cfg.law == "proportional" and (new or mu is not None):
            seen = max(abs(tang[f]) / normal[f] for f in fingers if normal[f] > 0.05)
            mu = seen if mu is None else max(mu, seen)
            for f in fingers:
                need = abs(tang[f]) / (cfg.ratio_margin * mu)
                target[f] = min(cfg.max_force_n, max(target[f], need))
        steps = {}
        for f in fingers:
            err = target[f] - level[f]
            if err > cfg.deadband * target[f]:
                steps[f] = min(err / cfg.stiffness_n_per_mm, cfg.max_step_mm)
                level[f] += steps[f] * cfg.stiffness_n_per_mm   # expected, until measured
        if steps:
            hand.step(steps)
            if det is not None:
                det.motion(now, max(steps.values()) / cfg.finger_speed_mm_s
                           + cfg.gate_margin_s)
        res.grip_n.append(float(np.mean(list(normal.values()))))
        if not running():
            return res
