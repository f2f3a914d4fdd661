"""A simulated two-finger hand holding an object that may slip (:mod:`..sim.physics.grasp`).

The fingers press the object's surface (stiffness of :class:`HeldObject`) and move towards
their commanded positions at ``finger_speed_mm_s`` (80 mm/s: a 50 mm finger link turning
at 1.6 rad/s). Time
advances one sensor period (80 Hz) per :meth:`SlipHand.read`, in 0.5 ms steps of the
stick-slip dynamics. A load (``added_kg``) is hung on the object at ``load_at_s``, rising
over ``load_rise_s`` (a sudden load: a few milliseconds). Each fingertip reads its normal and
tangential force through its virtual strain unit (the tangential force across the prism,
in its sensing plane) and its fitted force model, and hears the slip bursts and its own
finger's motor through the audio chain, rendered frame by frame.
"""
from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from ...device import Frame
from ..physics import AudioChain, Excitation, VirtualStrainSensor
from ..physics.disturbances import motor_noise
from ..physics.grasp import GraspSlip, HeldObject
from ..physics.touch import LINK_MM
from ..physics.vibration import place
from ...tasks.interfaces import AudioBlock, FrameSet, RobotHand
from .hand import RATE_SPS, tare_counts, unit_force_model

SLIP_FINGERS = ("f0", "f1")
SUBSTEP_S = 0.0005
BURST_TAU_S = 1.2e-3


@dataclass
class SlipTrial:
    obj: HeldObject
    grip_n: float
    """Initial normal force per finger."""
    added_kg: float
    load_at_s: float = 0.3
    load_rise_s: float = 0.005
    seed: int = 0
    finger_speed_mm_s: float = 80.0
    angles_deg: dict[str, float] = field(default_factory=dict)
    """Each fingertip's normal direction in its own frame (the hand's geometry)."""


class SlipHand(RobotHand):
    def __init__(self, trial: SlipTrial, unit_seeds: Mapping[str, int] | None = None) -> None:
        self.trial = trial
        rng = np.random.default_rng(np.random.SeedSequence([trial.seed, 0x511F]))
        self.rng = rng
        seeds = unit_seeds or {f: 100 + i for i, f in enumerate(SLIP_FINGERS)}
        self._sensors = {f: VirtualStrainSensor(seeds[f], rate_sps=RATE_SPS)
                         for f in SLIP_FINGERS}
        self._models = {f: unit_force_model(seeds[f]) for f in SLIP_FINGERS}
        self.angles = {f: trial.angles_deg.get(f, float(rng.uniform(-30, 30)))
                       for f in SLIP_FINGERS}
        self.t_s = 1.0
        self._tares = {f: tare_counts(s, self.t_s - 1.0) for f, s in self._sensors.items()}
        k = trial.obj.stiffness_n_per_mm
        self.gap = {f: float(rng.uniform(0.3, 1.3)) for f in SLIP_FINGERS}
        self.pos = {f: self.gap[f] + trial.grip_n / k for f in SLIP_FINGERS}
        self.target = dict(self.pos)
        self.grasp = GraspSlip(trial.obj, fingers=len(SLIP_FINGERS), rng=rng)
        self.grasp.t_s = self.t_s
        self.load_at = self.t_s + trial.load_at_s
        self.chain = AudioChain()
        self.fs = self.chain.fs
        self._audio_rng = np.random.default_rng(np.random.SeedSequence([trial.seed, 0xA0]))
        self._pending = {f: np.zeros(0) for f in SLIP_FINGERS}
        self._blocks: dict[str, list[np.ndarray]] = {f: [] for f in SLIP_FINGERS}
        self._cursor = {f: int(round(self.t_s * self.fs)) for f in SLIP_FINGERS}
        self._listening: set[str] = set()
        self._seq = 0
        self.normal_log: list[float] = []

    # --- RobotHand -------------------------------------------------------------------------

    @property
    def fingers(self) -> list[str]:
        return list(SLIP_FINGERS)

    def step(self, increments_mm: Mapping[str, float]) -> None:
        for f, d in increments_mm.items():
            self.target[f] = min(max(self.target[f] + float(d), 0.0), 30.0)

    def positions(self) -> dict[str, float]:
        return dict(self.pos)

    def force_model(self, finger: str):
        return self._models[finger]

    def normal_forces(self) -> np.ndarray:
        k = self.trial.obj.stiffness_n_per_mm
        return np.array([max(0.0, self.pos[f] - self.gap[f]) * k for f in SLIP_FINGERS])

    def read_audio(self, finger: str) -> AudioBlock:
        if finger not in SLIP_FINGERS:
            raise ValueError(f"no finger {finger!r}")
        self._listening.add(finger)
        blocks = self._blocks[finger]
        x = np.concatenate(blocks) if blocks else np.zeros(0, np.float32)
        blocks.clear()
        start = self._cursor[finger] - len(x)
        return AudioBlock(x, float(self.fs), start / self.fs)

    def read(self, timeout: float = 0.5) -> FrameSet | None:
        period = 1.0 / RATE_SPS
        t0 = self.t_s
        steps = int(round(period / SUBSTEP_S))
        sum_xy = {f: np.zeros(2) for f in SLIP_FINGERS}
        speeds = {f: np.zeros(steps) for f in SLIP_FINGERS}
        g = self.grasp
        for k in range(steps):
            for f in SLIP_FINGERS:
                d = self.target[f] - self.pos[f]
                mv = math.copysign(min(abs(d), self.trial.finger_speed_mm_s * SUBSTEP_S), d)
                self.pos[f] += mv
                speeds[f][k] = abs(mv) / SUBSTEP_S
            t = t0 + (k + 1) * SUBSTEP_S
            u = (t - self.load_at) / max(self.trial.load_rise_s, 1e-6)
            g.added_kg = self.trial.added_kg * min(max(u, 0.0), 1.0)
            n = self.normal_forces()
            g.step(SUBSTEP_S, n)
            tang = g.tangential(n)
            for i, f in enumerate(SLIP_FINGERS):
                a = math.radians(self.angles[f])
                sum_xy[f] += n[i] * np.array([math.cos(a), math.sin(a)]) \
                    + tang[i] * np.array([-math.sin(a), math.cos(a)])
        self.t_s = t0 + steps * SUBSTEP_S
        self.normal_log.append(float(self.normal_forces().mean()))
        self._render(t0, speeds)
        self._seq += 1
        out = {}
        for f in SLIP_FINGERS:
            fxy = (sum_xy[f] / steps)[None, :]
            c = self._sensors[f].counts_batch(fxy, 2.0, np.array([self.t_s]))
            counts = tuple(int(v) for v in np.rint(c[0] - self._tares[f]))
            out[f] = Frame(seq=self._seq, device_time_us=int(self.t_s * 1e6), host_time=self.t_s,
                           arrival_time=time.monotonic(), counts=counts)
        return out

    # --- audio -----------------------------------------------------------------------------

    def _render(self, t0: float, speeds: dict[str, np.ndarray]) -> None:
        fs = self.fs
        for i, f in enumerate(SLIP_FINGERS):
            if f not in self._listening:
                self._cursor[f] = int(round(self.t_s * fs))
                continue
            a = self._cursor[f]
            b = int(round(self.t_s * fs))
            n = b - a
            m = n + self.chain.pad
            pulses = [(t, amp) for t, amp, k in self.grasp.pulses if k == i and t >= a / fs
                      and t < b / fs]
            kern = np.exp(-np.arange(int(6 * BURST_TAU_S * fs)) / (BURST_TAU_S * fs))
            force = place(m, np.array([p[0] - a / fs for p in pulses]),
                          np.array([p[1] for p in pulses]), kern, fs)
            sp = np.repeat(speeds[f], int(math.ceil(n / len(speeds[f]))))[:n]
            if sp.any():
                force[:n] += motor_noise(n, fs, self._audio_rng, sp / LINK_MM)
            v = self.chain.filter([Excitation(force)], m)
            pend = self._pending[f]
            v[:len(pend)] += pend[:m]
            self._pending[f] = v[n:]
            self._blocks[f].append(self.chain.finish(v[:n].copy(), a, self._audio_rng).samples)
            self._cursor[f] = b


def run_hold_trial(trial: SlipTrial, reflex: str, hold_s: float = 1.0,
                   law: str = "coulomb") -> dict:
    """Hold ``trial``'s object with :func:`~fingertip.tasks.hold.hold` (its slip law ``law``)
    for ``hold_s`` while the load is added; the truth and what the recipe did."""
    from ...tasks.hold import HoldConfig, hold

    hand = SlipHand(trial)
    end = hand.t_s + hold_s
    # The object's stiffness is what the grip's closing would have measured (force per mm).
    cfg = HoldConfig(normal_deg=dict(hand.angles), reflex=reflex, law=law,
                     stiffness_n_per_mm=trial.obj.stiffness_n_per_mm,
                     finger_speed_mm_s=trial.finger_speed_mm_s,
                     max_step_mm=trial.finger_speed_mm_s / RATE_SPS)
    res = hold(hand, cfg, lambda: hand.t_s < end)
    g = hand.grasp
    after = [e for e in res.slip_events if e.time >= hand.load_at - 1e-9]
    latency = None
    if g.slip_onset_s is not None and after:
        latency = after[0].detected_at - g.slip_onset_s
    return {"seed": trial.seed, "object": trial.obj.name, "reflex": reflex, "ok": res.ok,
            "held": res.ok and not g.dropped, "slipped": g.slip_onset_s is not None,
            "slip_mm": g.slip_mm, "latency_s": latency,
            "source": after[0].source if after else None,
            "false_before_load": len(res.slip_events) - len(after),
            "mean_grip_n": float(np.mean(hand.normal_log)),
            "peak_grip_n": float(np.max(hand.normal_log))}


def slip_trials(n: int, seed: int = 0, load_range: tuple[float, float] = (0.2, 0.8),
                margin_range: tuple[float, float] = (1.15, 1.6)) -> list[SlipTrial]:
    """``n`` trials, seeds ``seed``..: the objects in turn, an initial grip of ``margin`` x
    the least that holds the object (log-uniform), a load of ``load_range`` x its mass added
    in 5 ms at 0.3 s."""
    from ..physics.grasp import HELD_OBJECTS

    names = list(HELD_OBJECTS)
    out = []
    for s in range(seed, seed + n):
        rng = np.random.default_rng(np.random.SeedSequence([s, 0x5A1]))
        o = HELD_OBJECTS[names[s % len(names)]]
        margin = math.exp(rng.uniform(math.log(margin_range[0]), math.log(margin_range[1])))
        grip = margin * o.mass_kg * 9.81 / (len(SLIP_FINGERS) * o.friction)
        out.append(SlipTrial(o, grip, float(rng.uniform(*load_range)) * o.mass_kg, seed=s))
    return out
