"""Stick and slip of an object held between fingertips, and what the piezos hear of it.

The object (mass ``mass_kg``, static friction ``friction`` against the skin, kinetic
``kinetic_ratio`` x that) hangs between ``fingers`` fingertips pressing with normal forces
N_i. Gravity and any added load pull it down with W = (m + added mass) g.

- Stick while W <= mu_s sum(N_i). Each fingertip carries W / n tangentially.
- Micro-slip (Cattaneo-Mindlin partial slip: the rim of each contact patch slips first):
  when the ratio rho = W / (mu_s sum N) exceeds ``micro_from`` (0.85), slip events occur at
  a rate growing as ((rho - micro_from) / (1 - micro_from))^2 up to ``micro_rate_hz``, each
  a small burst at the nail: ``burst_n_per_n`` x N_i (about a fifth of TPU's stick-slip
  pulse, :mod:`.materials`), a 1.2 ms exponential. Nothing moves yet.
- Gross slip when W > mu_s sum N: the object accelerates, (m + added) dv/dt = W - mu_k sum N,
  and sticks again when v returns to 0 with W <= mu_s sum N. While it slides, each
  fingertip feels stick-slip pulses every ``slip_spacing_mm`` of travel (2.5 x the burst)
  and carries mu_k N_i tangentially. The first gross slip is the truth of ``slip_onset``.
- Dropped: the object slid ``drop_mm`` (out of the fingertips' pads).

:class:`GraspSlip` is integrated by the caller in small steps (:meth:`step`), with the normal
forces the hand applies at each step; it records the truth and the nail-force pulses
(times, amplitudes, finger) for the audio.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

G = 9.81


@dataclass(frozen=True)
class HeldObject:
    name: str
    mass_kg: float
    friction: float
    kinetic_ratio: float = 0.8
    stiffness_n_per_mm: float = 1.0
    """Of the object's surface under a fingertip (grip force per mm of squeeze)."""
    burst_n_per_n: float = 0.003
    slip_spacing_mm: float = 0.15

    def __post_init__(self) -> None:
        if self.mass_kg <= 0 or self.friction <= 0 or not 0 < self.kinetic_ratio <= 1:
            raise ValueError("mass and friction must be > 0, kinetic_ratio in (0, 1]")


HELD_OBJECTS: dict[str, HeldObject] = {o.name: o for o in (
    HeldObject("plastic_cup", 0.05, 0.45, stiffness_n_per_mm=0.8),
    HeldObject("wooden_block", 0.12, 0.55, stiffness_n_per_mm=3.0),
    HeldObject("glass_jar", 0.25, 0.35, stiffness_n_per_mm=3.0),
    HeldObject("rubber_ball", 0.08, 0.9, stiffness_n_per_mm=0.5, burst_n_per_n=0.004),
    HeldObject("cardboard_box", 0.15, 0.5, stiffness_n_per_mm=1.2),
)}
"""Objects of different mass and friction (friction of silicone skin on each, ours)."""


@dataclass
class GraspSlip:
    obj: HeldObject
    fingers: int = 2
    drop_mm: float = 10.0
    micro_from: float = 0.85
    micro_rate_hz: float = 300.0
    rng: np.random.Generator = field(default_factory=lambda: np.random.default_rng(0))
    added_kg: float = 0.0
    slip_mm: float = 0.0
    speed_mm_s: float = 0.0
    t_s: float = 0.0
    slip_onset_s: float | None = None
    """First gross slip (the truth)."""
    slip_starts_s: list[float] = field(default_factory=list)
    micro_s: list[float] = field(default_factory=list)
    pulses: list[tuple[float, float, int]] = field(default_factory=list)
    """(time, nail force amplitude N, finger) of every burst and stick-slip pulse."""
    _next_pulse_mm: float = 0.0

    @property
    def weight_n(self) -> float:
        return (self.obj.mass_kg + self.added_kg) * G

    @property
    def dropped(self) -> bool:
        return self.slip_mm >= self.drop_mm

    @property
    def sliding(self) -> bool:
        return self.speed_mm_s > 0

    def ratio(self, normal_n: np.ndarray) -> float:
        """W / (mu_s sum N): slip starts at 1."""
        s = float(np.sum(normal_n))
        return math.inf if s <= 0 else self.weight_n / (self.obj.friction * s)

    def tangential(self, normal_n: np.ndarray) -> np.ndarray:
        """Each fingertip's tangential (upward on the object) force now."""
        n = np.asarray(normal_n, float)
        if self.sliding or self.dropped:
            return self.obj.friction * self.obj.kinetic_ratio * n
        return np.full(n.shape, self.weight_n / len(n))

    def step(self, dt: float, normal_n: np.ndarray) -> None:
        """Advance ``dt`` seconds with the fingertips pressing ``normal_n`` (one per finger)."""
        n = np.maximum(np.asarray(normal_n, float), 0.0)
        if n.shape != (self.fingers,):
            raise ValueError(f"need {self.fingers} normal forces")
        t0 = self.t_s
        self.t_s += dt
        if self.dropped:
            return
        o = self.obj
        rho = self.ratio(n)
        if not self.sliding:
            if rho > 1.0:
                self.speed_mm_s = 1e-6
                self._next_pulse_mm = self.slip_mm + o.slip_spacing_mm
                self.slip_starts_s.append(t0)
                if self.slip_onset_s is None:
                    self.slip_onset_s = t0
                for i in range(self.fingers):
                    self.pulses.append((t0, 2.5 * o.burst_n_per_n * n[i], i))
            elif rho > self.micro_from:
                rate = self.micro_rate_hz * ((rho - self.micro_from) / (1 - self.micro_from)) ** 2
                for _ in range(self.rng.poisson(rate * dt)):
                    t = t0 + self.rng.uniform(0, dt)
                    i = int(self.rng.integers(self.fingers))
                    self.micro_s.append(t)
                    self.pulses.append((t, o.burst_n_per_n * n[i]
                                        * math.exp(0.3 * self.rng.standard_normal()), i))
                return
            else:
                return
        mass = o.mass_kg + self.added_kg
        acc = (self.weight_n - o.friction * o.kinetic_ratio * float(n.sum())) / mass * 1e3
        v0 = self.speed_mm_s
        v1 = v0 + acc * dt
        if v1 <= 0:
            # Stops within the step: sticks again.
            tau = v0 / -acc if acc < 0 else dt
            self.slip_mm += 0.5 * v0 * tau
            self.speed_mm_s = 0.0
            return
        x0 = self.slip_mm
        self.slip_mm += 0.5 * (v0 + v1) * dt
        self.speed_mm_s = v1
        # Stick-slip pulses at every slip_spacing_mm travelled, on every finger.
        while self._next_pulse_mm < self.slip_mm:
            if self._next_pulse_mm >= x0:
                frac = (self._next_pulse_mm - x0) / max(self.slip_mm - x0, 1e-12)
                for i in range(self.fingers):
                    self.pulses.append((t0 + frac * dt, -2.5 * o.burst_n_per_n * n[i]
                                        * math.exp(0.25 * self.rng.standard_normal()), i))
            self._next_pulse_mm += o.slip_spacing_mm * math.exp(0.2 * self.rng.standard_normal())
        if self.slip_mm >= self.drop_mm:
            self.slip_mm = self.drop_mm
