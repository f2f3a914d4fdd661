"""Hold an object and keep it: raise the grip force when it starts to slip.

:func:`hold` keeps each finger's normal force at a target (closing a finger whose force is
below it, proportionally, at most ``max_step_mm`` per frame) and, on each ``slip_onset`` of a
:class:`~fingertip.events.slip.SlipDetector` (piezo bursts and the force ratio, or the force
ratio alone), raises every target by ``raise_fraction`` (at most ``max_force_n``). Without a
reflex (``reflex="none"``) it only keeps the initial force, as the paper's hold does.

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
    raise_fraction: float = 0.5
    """At a slip onset every target rises at once by this fraction (the force ratio at that
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


def hold(hand: RobotHand, cfg: HoldConfig, running: Callable[[], bool]) -> HoldResult:
    """Hold while ``running()`` is true (checked once per frame)."""
    if cfg.reflex not in ("fused", "force", "none"):
        raise ValueError(f"reflex must be fused, force or none, not {cfg.reflex!r}")
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
        if new:
            for f in fingers:
                target[f] = min(cfg.max_force_n,
                                max(target[f], level[f]) * (1 + cfg.raise_fraction))
        if new or mu is not None:
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
