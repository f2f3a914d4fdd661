"""The force-threshold grip shared by every recipe: close step by step to ``F_th``, then hold.

:class:`Grip` runs the paper's controller on any subset of fingers (all four for the pinch
and the cups, two opposite ones for a box): it zeroes each finger's force estimate with the
fingers open (as a vector: a calibrated model's estimate at rest is a small force in some
direction, and subtracting magnitudes would hide or double it), closes every finger whose
filtered force (a short moving average of the calibrated force magnitude) is below
``F_th`` by one increment per sensor frame, and then holds the force (re-closing a finger
whose force sags) for as long as the caller's motion lasts. It aborts to a safe state (arm
stopped, fingers opened) on a force above ``max_force_n``, a timeout, or a sensor fault (no
frames, timeout/saturation bits, non-finite estimates); :attr:`Grip.result` says why.
"""
from __future__ import annotations

import enum
import math
import time
from collections import deque
from collections.abc import Callable, Sequence
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
    """The grip force per finger (from a demonstration)."""
    step_mm: float = 0.02
    """Closing increment per frame."""
    max_force_n: float | None = None
    """Abort above this filtered force on any finger (default: 3 x ``f_th_n`` + 0.1 N)."""
    window: int = 4
    """Moving-average length (frames)."""
    baseline_frames: int = 8
    """Frames read with the fingers open to zero each finger's force estimate."""
    timeout_s: float = 20.0
    """Whole grip (close, then hold), in frame time."""
    read_timeout_s: float = 0.5
    lift_mm: float = 20.0
    lift_speed_mm_s: float = 20.0
    hold_band: float = 0.8
    """While holding, re-close a finger whose force falls below ``hold_band * f_th_n``."""
    approach_speed_mm_s: float | None = None
    """Close at this speed until each finger's contact detector fires, then regulate with
    the steps (:mod:`.approach`); None: the paper's step per frame from the start."""

    @property
    def max_force(self) -> float:
        return self.max_force_n if self.max_force_n is not None else 3 * self.f_th_n + 0.1


@dataclass
class PinchResult:
    outcome: PinchOutcome
    detail: str = ""
    frames: int = 0
    forces_n: dict[str, float] = field(default_factory=dict)
    """Each finger's filtered force when the grip ended."""
    peak_n: float = 0.0
    latencies_ms: list[float] = field(default_factory=list)
    """Per frame: from the frame set's arrival to the command sent for it."""
    contacts: dict[str, object] = field(default_factory=dict)
    """With an approach at speed: each finger's contact event that stopped it."""

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


def force_magnitudes(hand: RobotHand, frames: FrameSet, fingers: Sequence[str]
                     ) -> dict[str, float]:
    """Each finger's calibrated force magnitude in one frame set; SensorFault when a frame is
    missing, flagged or gives a non-finite estimate."""
    return {f: math.hypot(*v) for f, v in force_vectors(hand, frames, fingers).items()}


def force_vectors(hand: RobotHand, frames: FrameSet, fingers: Sequence[str]
                  ) -> dict[str, tuple[float, float]]:
    """Each finger's calibrated (Fx, Fy) in one frame set (SensorFault as above)."""
    out = {}
    for f in fingers:
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
        out[f] = (fx, fy)
    return out


class Grip:
    """One grip of ``fingers`` (default: all of the hand's) at ``cfg.f_th_n``.

    Call :meth:`close`, then :meth:`hold` as many times as the task has motions; each
    returns False after an abort (then :attr:`result` holds the outcome and the fingers are
    open). ``arm`` (optional) is stopped on an abort.
    """

    def __init__(self, hand: RobotHand, cfg: PinchConfig, fingers: Sequence[str] | None = None,
                 arm: RobotArm | None = None) -> None:
        self.hand = hand
        self.cfg = cfg
        self.arm = arm
        self.fingers = list(fingers) if fingers is not None else list(hand.fingers)
        unknown = set(self.fingers) - set(hand.fingers)
        if unknown or not self.fingers:
            raise ValueError(f"fingers must be among {hand.fingers}, not {sorted(unknown)}")
        self.result = PinchResult(PinchOutcome.HELD)
        self._bufs: dict[str, deque] = {f: deque(maxlen=cfg.window) for f in self.fingers}
        self._baseline = dict.fromkeys(self.fingers, (0.0, 0.0))
        self.zeroed = False
        self._t0: float | None = None
        self._arrival = 0.0
        self.now = 0.0
        """Time (the frames' host clock) of the latest frame set."""
        self.frames: FrameSet = {}
        """The latest frame set read (every finger's, for an ``on_frame`` that needs more)."""

    def _abort(self, outcome: PinchOutcome, detail: str) -> bool:
        if self.arm is not None:
            self.arm.stop()
        self.hand.open_fully()
        self.result.outcome, self.result.detail = outcome, detail
        return False

    def _read(self) -> tuple[dict[str, tuple[float, float]], float] | None:
        """One frame set -> (each finger's (Fx, Fy), arrival time); None: aborted."""
        frames = self.hand.read(self.cfg.read_timeout_s)
        if frames is None:
            self._abort(PinchOutcome.SENSOR_FAULT, "no frames")
            return None
        self.result.frames += 1
        self.frames = frames
        arrival = max(fr.arrival_time for fr in frames.values())
        self.now = max(fr.host_time for fr in frames.values())
        self._t0 = self.now if self._t0 is None else self._t0
        try:
            return force_vectors(self.hand, frames, self.fingers), arrival
        except SensorFault as e:
            self._abort(PinchOutcome.SENSOR_FAULT, str(e))
            return None

    def _filtered(self, vecs: dict[str, tuple[float, float]], phase: str
                  ) -> dict[str, float] | None:
        """Moving averages of the baseline-corrected force magnitudes; None after a force or
        timeout abort."""
        cfg, res = self.cfg, self.result
        filt = {}
        for f, (fx, fy) in vecs.items():
            bx, by = self._baseline[f]
            self._bufs[f].append(math.hypot(fx - bx, fy - by))
            filt[f] = sum(self._bufs[f]) / len(self._bufs[f])
        res.forces_n = filt
        res.peak_n = max(res.peak_n, max(filt.values()))
        if res.peak_n > cfg.max_force:
            self._abort(PinchOutcome.MAX_FORCE, f"{res.peak_n:.3f} N > {cfg.max_force:.3f} N")
            return None
        assert self._t0 is not None
        if self.now - self._t0 > cfg.timeout_s:
            self._abort(PinchOutcome.TIMEOUT, f"after {self.now - self._t0:.2f} s in phase "
                                              f"{phase}")
            return None
        return filt

    def _next(self, phase: str) -> dict[str, float] | None:
        """The next frame set's filtered forces; None after an abort."""
        got = self._read()
        if got is None:
            return None
        self._arrival = got[1]
        return self._filtered(got[0], phase)

    def _command(self, cmd: dict[str, float]) -> None:
        """Send the closing steps for the latest frame set and time the loop's work."""
        if cmd:
            self.hand.step(cmd)
        self.result.latencies_ms.append((time.monotonic() - self._arrival) * 1e3)

    @property
    def started_at(self) -> float | None:
        """Time (the frames' clock) of the grip's first frame; None before it."""
        return self._t0

    def abort(self, outcome: PinchOutcome, detail: str) -> bool:
        """Stop the arm, open the fingers, record why; returns False."""
        return self._abort(outcome, detail)

    def forces(self, frames: FrameSet) -> dict[str, float] | None:
        """Each finger's baseline-corrected force magnitude in ``frames`` (unfiltered); None
        after an abort (a sensor fault, or a force above ``max_force``)."""
        self.result.frames += 1
        self.now = max(fr.host_time for fr in frames.values())
        self._t0 = self.now if self._t0 is None else self._t0
        try:
            vecs = force_vectors(self.hand, frames, self.fingers)
        except SensorFault as e:
            self._abort(PinchOutcome.SENSOR_FAULT, str(e))
            return None
        out = {}
        for f, (fx, fy) in vecs.items():
            bx, by = self._baseline[f]
            out[f] = math.hypot(fx - bx, fy - by)
        peak = max(out.values())
        self.result.peak_n = max(self.result.peak_n, peak)
        if peak > self.cfg.max_force:
            self._abort(PinchOutcome.MAX_FORCE, f"{peak:.3f} N > {self.cfg.max_force:.3f} N")
            return None
        return out

    def zero(self) -> bool:
        """Zero each finger's force estimate on ``baseline_frames`` frames (fingers open)."""
        rows: list[dict[str, tuple[float, float]]] = []
        while len(rows) < self.cfg.baseline_frames:
            got = self._read()
            if got is None:
                return False
            rows.append(got[0])
        self._baseline = {f: (float(np.mean([r[f][0] for r in rows])),
                              float(np.mean([r[f][1] for r in rows]))) for f in self.fingers}
        self.zeroed = True
        return True

    def close(self) -> bool:
        """Zero the estimates (fingers open) unless :meth:`zero` did, then close until
        every finger reaches F_th."""
        if not self.zeroed and not self.zero():
            return False
        while True:
            got = self._next("close")
            if got is None:
                return False
            cmd = {f: self.cfg.step_mm for f, v in got.items() if v < self.cfg.f_th_n}
            self._command(cmd)
            if not cmd:
                return True

    def hold(self, running: Callable[[], bool],
             on_frame: Callable[[float], None] | None = None) -> bool:
        """Hold the force while ``running()`` is true (checked after each frame's command);
        ``on_frame(now)`` runs once per frame after the command (the task's own work)."""
        band = self.cfg.hold_band * self.cfg.f_th_n
        while True:
            got = self._next("hold")
            if got is None:
                return False
            self._command({f: self.cfg.step_mm for f, v in got.items() if v < band})
            if on_frame is not None:
                on_frame(self.now)
            if not running():
                return True
