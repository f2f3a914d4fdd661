"""The force-threshold pinch (the paper's tofu and potato-chip grasps).

One demonstration records the pinch force ``F_th`` (:func:`demonstrate_threshold`). Then
:func:`pinch` steps every finger closed, one increment per sensor frame, until that
finger's filtered force (a short moving average of the calibrated force magnitude) reaches
``F_th``; it then holds the force (re-closing a finger whose force sags) while the arm lifts.
It aborts to a safe state (arm stopped, fingers opened) on a force above ``max_force_n``, a
timeout, or a sensor fault (no frames, timeout/saturation bits, non-finite estimates).
"""
from __future__ import annotations

import enum
import math
import time
from collections import deque
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np

from .interfaces import FrameSet, RobotArm, RobotHand


class PinchOutcome(enum.Enum):
    HELD = "held"
    MAX_FORCE = "max force"
    TIMEOUT = "timeout"
    SENSOR_FAULT = "sensor fault"


@dataclass
class PinchConfig:
    f_th_n: float
    """The pinch force per finger (from a demonstration)."""
    step_mm: float = 0.02
    """Closing increment per frame."""
    max_force_n: float | None = None
    """Abort above this filtered force on any finger (default: 3 x ``f_th_n`` + 0.1 N)."""
    window: int = 4
    """Moving-average length (frames)."""
    baseline_frames: int = 8
    """Frames read with the fingers open to zero each finger's force estimate."""
    timeout_s: float = 20.0
    """Whole pinch (close + lift), in frame time."""
    read_timeout_s: float = 0.5
    lift_mm: float = 20.0
    lift_speed_mm_s: float = 20.0
    hold_band: float = 0.8
    """While holding, re-close a finger whose force falls below ``hold_band * f_th_n``."""

    @property
    def max_force(self) -> float:
        return self.max_force_n if self.max_force_n is not None else 3 * self.f_th_n + 0.1


@dataclass
class PinchResult:
    outcome: PinchOutcome
    detail: str = ""
    frames: int = 0
    forces_n: dict[str, float] = field(default_factory=dict)
    """Each finger's filtered force when the pinch ended."""
    peak_n: float = 0.0
    latencies_ms: list[float] = field(default_factory=list)
    """Per frame: from the frame set's arrival to the command sent for it."""

    @property
    def ok(self) -> bool:
        return self.outcome is PinchOutcome.HELD

    @property
    def latency_ms(self) -> dict[str, float]:
        a = np.asarray(self.latencies_ms) if self.latencies_ms else np.zeros(1)
        return {"median": float(np.median(a)), "p99": float(np.percentile(a, 99)),
                "max": float(a.max())}


class SensorFault(RuntimeError):
    pass


def _magnitudes(hand: RobotHand, frames: FrameSet) -> dict[str, float]:
    out = {}
    for f in hand.fingers:
        fr = frames.get(f)
        if fr is None:
            raise SensorFault(f"no frame from finger {f}")
        if not fr.ok:
            raise SensorFault(f"finger {f}: timeout bits {fr.timeout_mask:#x}, saturation "
                              f"bits {fr.saturation_mask:#x}")
        est = hand.force_model(f).estimate_frame(fr)
        fx, fy = float(est.fx), float(est.fy)
        if not (math.isfinite(fx) and math.isfinite(fy)):
            raise SensorFault(f"finger {f}: non-finite force estimate")
        out[f] = math.hypot(fx, fy)
    return out


def demonstrate_threshold(forces_n: Iterable[Mapping[str, float]], window: int = 4) -> float:
    """``F_th`` from one demonstration: per-finger force magnitudes, one mapping per frame,
    recorded while a person pinches the object as firmly as the task needs. Returns the
    median over fingers of each finger's plateau (the median of its filtered force over the
    frames where it is above half its peak)."""
    rows = list(forces_n)
    if not rows:
        raise ValueError("empty demonstration")
    plateaus = []
    for f in rows[0]:
        x = np.array([r[f] for r in rows], float)
        if len(x) >= window:
            x = np.convolve(x, np.ones(window) / window, mode="valid")
        peak = x.max()
        if peak > 0:
            plateaus.append(float(np.median(x[x >= peak / 2])))
    if not plateaus:
        raise ValueError("no force in the demonstration")
    return float(np.median(plateaus))


def pinch(hand: RobotHand, arm: RobotArm | None, cfg: PinchConfig) -> PinchResult:
    """Close to ``cfg.f_th_n`` on every finger, then hold while the arm lifts."""
    res = PinchResult(PinchOutcome.HELD)
    bufs: dict[str, deque] = {f: deque(maxlen=cfg.window) for f in hand.fingers}
    baseline = dict.fromkeys(hand.fingers, 0.0)
    t0 = None
    phase = "baseline"
    base_rows: list[dict[str, float]] = []

    def abort(outcome: PinchOutcome, detail: str) -> PinchResult:
        if arm is not None:
            arm.stop()
        hand.open_fully()
        res.outcome, res.detail = outcome, detail
        return res

    while True:
        frames = hand.read(cfg.read_timeout_s)
        if frames is None:
            return abort(PinchOutcome.SENSOR_FAULT, "no frames")
        res.frames += 1
        arrival = max(fr.arrival_time for fr in frames.values())
        now = max(fr.host_time for fr in frames.values())
        t0 = now if t0 is None else t0
        try:
            mags = _magnitudes(hand, frames)
        except SensorFault as e:
            return abort(PinchOutcome.SENSOR_FAULT, str(e))
        if phase == "baseline":
            base_rows.append(mags)
            if len(base_rows) >= cfg.baseline_frames:
                baseline = {f: float(np.mean([r[f] for r in base_rows])) for f in mags}
                phase = "close"
            continue
        filt = {}
        for f, m in mags.items():
            bufs[f].append(m - baseline[f])
            filt[f] = sum(bufs[f]) / len(bufs[f])
        res.forces_n = filt
        res.peak_n = max(res.peak_n, max(filt.values()))
        if res.peak_n > cfg.max_force:
            return abort(PinchOutcome.MAX_FORCE, f"{res.peak_n:.3f} N > {cfg.max_force:.3f} N")
        if now - t0 > cfg.timeout_s:
            return abort(PinchOutcome.TIMEOUT, f"after {now - t0:.2f} s in phase {phase}")
        if phase == "close":
            cmd = {f: cfg.step_mm for f, v in filt.items() if v < cfg.f_th_n}
            if cmd:
                hand.step(cmd)
            elif arm is not None:
                arm.slide_z(cfg.lift_mm, cfg.lift_speed_mm_s)
                phase = "lift"
            else:
                phase = "done"
        elif phase == "lift":
            cmd = {f: cfg.step_mm for f, v in filt.items() if v < cfg.hold_band * cfg.f_th_n}
            if cmd:
                hand.step(cmd)
            if not arm.moving():
                phase = "done"
        res.latencies_ms.append((time.monotonic() - arrival) * 1e3)
        if phase == "done":
            return res
