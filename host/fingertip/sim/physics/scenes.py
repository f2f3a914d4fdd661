"""Scenes: what happens to the fingertip, and which signals that needs.

A scene is a frozen description (its randomness comes from its own ``seed``, so its ground
truth is known without simulating anything). It declares the signals it needs in ``needs``
("force", "vibration" or both; ``signals=`` overrides the scene's default) and provides:

- ``forces(t)``: the quasi-static load on the cap at scene times ``t`` (s): force in the XY
  plane (N, the force the object applies to the fingertip), contact height (mm below the
  nail tip) and axial force (N, compressive positive);
- ``excitation(n, fs)``: the dynamic force at the nail as :class:`~.vibration.Excitation`
  segments, for the contact microphone;
- ``events()``: ground truth (contact times, rim times and heights, impact times, ...).

:func:`~.simulate.simulate` calls only what ``needs`` lists.
"""
from __future__ import annotations

from abc import ABC, abstractmethod

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, ClassVar

import numpy as np

from .materials import CUP_WALL, material
from .vibration import (
    Excitation,
    damped_sine,
    half_sine,
    place,
    slide_excitation,
    smooth_noise,
)

FORCE = "force"
VIBRATION = "vibration"
SIGNALS = (FORCE, VIBRATION)


@dataclass(frozen=True)
class Forces:
    xy: np.ndarray
    """(N, 2) force on the fingertip in its XY plane, N."""
    height_mm: np.ndarray
    """(N,) contact height below the nail tip, mm."""
    z: np.ndarray
    """(N,) axial force, N, compressive positive."""

    @classmethod
    def zeros(cls, n: int, height_mm: float = 0.0) -> Forces:
        return cls(np.zeros((n, 2)), np.full(n, float(height_mm)), np.zeros(n))

    @classmethod
    def polar(cls, magnitude: np.ndarray, angle_deg: float | np.ndarray,
              height_mm: float | np.ndarray, z: float | np.ndarray = 0.0) -> Forces:
        mag = np.asarray(magnitude, float)
        a = np.radians(np.broadcast_to(np.asarray(angle_deg, float), mag.shape))
        return cls(np.stack([mag * np.cos(a), mag * np.sin(a)], axis=1),
                   np.broadcast_to(np.asarray(height_mm, float), mag.shape).copy(),
                   np.broadcast_to(np.asarray(z, float), mag.shape).copy())


class Scene(ABC):
    """Base class. Subclasses are frozen dataclasses with ``signals`` and ``seed`` fields."""

    default_signals: ClassVar[tuple[str, ...]] = (FORCE,)
    signals: tuple[str, ...] | None
    seed: int

    @property
    def name(self) -> str:
        return type(self).__name__

    @property
    def needs(self) -> frozenset[str]:
        s = frozenset(self.default_signals if self.signals is None else self.signals)
        unknown = s - set(SIGNALS)
        if unknown:
            raise ValueError(f"unknown signals {sorted(unknown)}; known: {SIGNALS}")
        return s

    @property
    @abstractmethod
    def duration_s(self) -> float:
        """How long the scene lasts, in seconds."""

    def forces(self, t: np.ndarray) -> Forces:
        return Forces.zeros(len(np.atleast_1d(t)))

    def excitation(self, n: int, fs: int) -> list[Excitation]:
        return []

    def events(self) -> dict[str, Any]:
        return {}

    def rng(self, stream: int) -> np.random.Generator:
        """The scene's random stream ``stream`` (its realisation: textures, jitter)."""
        tag = sum(self.name.encode())
        return np.random.default_rng(np.random.SeedSequence([self.seed, tag, stream]))


def _is_nail(height_mm: float) -> bool:
    return height_mm < 1.0


def _transient(n: int, fs: int, times: Sequence[float], amps: Sequence[float],
               duration_s: float) -> np.ndarray:
    return place(n, np.asarray(times), np.asarray(amps), half_sine(duration_s, fs), fs)


@dataclass(frozen=True)
class Idle(Scene):
    """Nothing touches the fingertip: zero force, the microphone's noise floor and hum."""

    duration: float = 1.0
    signals: tuple[str, ...] | None = None
    seed: int = 0
    default_signals: ClassVar[tuple[str, ...]] = (FORCE, VIBRATION)

    @property
    def duration_s(self) -> float:
        return self.duration


@dataclass(frozen=True)
class Press(Scene):
    """A press at a fixed angle and height: ramp up to ``peak_n``, hold, ramp down (loading
    and unloading, as in the paper's characterisation)."""

    angle_deg: float = 0.0
    height_mm: float = 0.0
    peak_n: float = 5.0
    ramp_s: float = 2.0
    hold_s: float = 1.0
    pre_s: float = 0.5
    post_s: float = 1.0
    signals: tuple[str, ...] | None = None
    seed: int = 0

    @property
    def duration_s(self) -> float:
        return self.pre_s + 2 * self.ramp_s + self.hold_s + self.post_s

    def magnitude(self, t: np.ndarray) -> np.ndarray:
        a = self.pre_s
        knots = [0.0, a, a + self.ramp_s, a + self.ramp_s + self.hold_s,
                 a + 2 * self.ramp_s + self.hold_s]
        return np.interp(t, knots, [0.0, 0.0, self.peak_n, self.peak_n, 0.0])

    def forces(self, t: np.ndarray) -> Forces:
        t = np.atleast_1d(np.asarray(t, float))
        return Forces.polar(self.magnitude(t), self.angle_deg, self.height_mm)

    def events(self) -> dict[str, Any]:
        return {"contact_make_s": self.pre_s,
                "contact_break_s": self.pre_s + 2 * self.ramp_s + self.hold_s,
                "peak_n": self.peak_n}

    def excitation(self, n: int, fs: int) -> list[Excitation]:
        ev = self.events()
        nail = _is_nail(self.height_mm)
        rate = self.peak_n / max(self.ramp_s, 1e-3)          # N/s: a slow press is quiet
        amp = 0.004 * min(rate, 50.0) * (1.0 if nail else 0.4)
        f = _transient(n, fs, [ev["contact_make_s"], ev["contact_break_s"]], [amp, -0.3 * amp],
                       3e-4 if nail else 3e-3)
        return [Excitation(f)]


@dataclass(frozen=True)
class ContactMakeBreak(Scene):
    """Touch, hold, release, ``repeats`` times: fast force steps with make/break transients."""

    angle_deg: float = 0.0
    height_mm: float = 0.0
    force_n: float = 1.5
    approach_speed_mm_s: float = 30.0
    pre_s: float = 0.3
    rise_s: float = 0.02
    hold_s: float = 0.8
    fall_s: float = 0.01
    post_s: float = 0.4
    repeats: int = 1
    signals: tuple[str, ...] | None = None
    seed: int = 0
    default_signals: ClassVar[tuple[str, ...]] = (FORCE, VIBRATION)

    @property
    def cycle_s(self) -> float:
        return self.rise_s + self.hold_s + self.fall_s + self.post_s

    @property
    def duration_s(self) -> float:
        return self.pre_s + self.repeats * self.cycle_s

    def events(self) -> dict[str, Any]:
        make = [self.pre_s + k * self.cycle_s for k in range(self.repeats)]
        brk = [m + self.rise_s + self.hold_s for m in make]
        return {"contact_make_s": make, "contact_break_s": brk}

    def forces(self, t: np.ndarray) -> Forces:
        t = np.atleast_1d(np.asarray(t, float))
        tc = np.mod(t - self.pre_s, self.cycle_s)
        inside = (t >= self.pre_s) & (t < self.duration_s)
        up = np.clip(tc / self.rise_s, 0, 1)
        down = np.clip((tc - self.rise_s - self.hold_s) / self.fall_s, 0, 1)
        shape = 0.5 - 0.5 * np.cos(np.pi * up) - (0.5 - 0.5 * np.cos(np.pi * down))
        return Forces.polar(np.where(inside, self.force_n * shape, 0.0), self.angle_deg,
                            self.height_mm)

    def excitation(self, n: int, fs: int) -> list[Excitation]:
        ev = self.events()
        rng = self.rng(1)
        nail = _is_nail(self.height_mm)
        k = len(ev["contact_make_s"])
        make = 0.004 * self.approach_speed_mm_s * (1.0 if nail else 0.4) \
            * np.exp(0.15 * rng.standard_normal(k))
        f = _transient(n, fs, ev["contact_make_s"], make, 3e-4 if nail else 3e-3)
        f += _transient(n, fs, ev["contact_break_s"], -0.35 * make, 5e-4 if nail else 2e-3)
        return [Excitation(f)]


@dataclass(frozen=True)
class Slide(Scene):
    """The nail sliding over a material at a speed and normal force (the paper slides 16 mm).
    ``make_break`` adds a touch before and a lift-off after the slide."""

    material: str = "coarse_fabric"
    speed_mm_s: float = 20.0
    normal_n: float = 1.0
    duration: float = 0.8
    angle_deg: float = 0.0
    make_break: bool = False
    lead_s: float = 0.2
    variability: float = 1.0
    signals: tuple[str, ...] | None = None
    seed: int = 0
    default_signals: ClassVar[tuple[str, ...]] = (VIBRATION,)

    def __post_init__(self) -> None:
        material(self.material)  # validates the name

    @property
    def start_s(self) -> float:
        return self.lead_s if self.make_break else 0.0

    @property
    def duration_s(self) -> float:
        return self.duration + (2 * self.lead_s if self.make_break else 0.0)

    def events(self) -> dict[str, Any]:
        ev: dict[str, Any] = {"material": material(self.material).name,
                              "slide_start_s": self.start_s,
                              "slide_end_s": self.start_s + self.duration}
        if self.make_break:
            ev["contact_make_s"] = self.start_s
            ev["contact_break_s"] = self.start_s + self.duration
        return ev

    def forces(self, t: np.ndarray) -> Forces:
        t = np.atleast_1d(np.asarray(t, float))
        a, b = self.start_s, self.start_s + self.duration
        ramp = 0.02
        mag = self.normal_n * np.clip(np.minimum(t - a + ramp, b - t) / ramp, 0, 1)
        if not self.make_break:
            mag = np.where((t >= 0) & (t <= self.duration), self.normal_n, 0.0)
        mat = material(self.material)
        return Forces.polar(mag, self.angle_deg, 0.0, mat.friction * mag)

    def excitation(self, n: int, fs: int) -> list[Excitation]:
        mat = material(self.material)
        i0 = int(round(self.start_s * fs))
        m = max(0, min(n - i0, int(round(self.duration * fs))))
        out = []
        if m > 0:
            f, info = slide_excitation(mat, self.speed_mm_s, self.normal_n, m, fs, self.rng(1),
                                       variability=self.variability)
            fade = min(m // 2, int(0.005 * fs))
            if fade:
                ramp = np.linspace(0, 1, fade)
                f[:fade] *= ramp
                f[-fade:] *= ramp[::-1]
            out.append(Excitation(f, i0, info["lowpass_hz"]))
        if self.make_break:
            amp = 0.004 * 20.0 * self.normal_n
            f = _transient(n, fs, [self.start_s], [amp], 3e-4)
            f += _transient(n, fs, [self.start_s + self.duration], [-0.35 * amp], 5e-4)
            out.append(Excitation(f))
        return out


@dataclass(frozen=True)
class CupStackSlide(Scene):
    """The nail sliding down the outside of a stack of paper cups, over their rims.

    The paper: five cups, a 21 mm slide passing three rims; rims ``pitch_mm`` apart (ours:
    7 mm). The slide starts ``start_above_mm`` above the top rim at robot height
    ``z_start_mm`` and moves down at ``speed_mm_s``.
    """

    speed_mm_s: float = 10.0
    n_cups: int = 5
    pitch_mm: float = 7.0
    slide_mm: float = 21.0
    start_above_mm: float = 3.5
    z_start_mm: float = 0.0
    normal_n: float = 0.4
    rim_width_mm: float = 1.0
    rim_jitter_mm: float = 0.2
    pre_s: float = 0.3
    post_s: float = 0.3
    signals: tuple[str, ...] | None = None
    seed: int = 0
    default_signals: ClassVar[tuple[str, ...]] = (VIBRATION,)

    @property
    def duration_s(self) -> float:
        return self.pre_s + self.slide_mm / self.speed_mm_s + self.post_s

    @cached_property
    def _rims(self) -> tuple[np.ndarray, np.ndarray]:
        rng = self.rng(0)
        k = np.arange(self.n_cups)
        offsets = self.start_above_mm + k * self.pitch_mm \
            + self.rim_jitter_mm * rng.standard_normal(self.n_cups)
        strength = np.exp(0.2 * rng.standard_normal(self.n_cups))
        return offsets, strength

    def z_mm(self, t: np.ndarray | float) -> np.ndarray:
        """Robot Z of the nail at scene time t (moves down during the slide)."""
        s = np.clip((np.asarray(t, float) - self.pre_s) * self.speed_mm_s, 0, self.slide_mm)
        return self.z_start_mm - s

    def events(self) -> dict[str, Any]:
        offsets, _ = self._rims
        passed = offsets < self.slide_mm
        return {"rim_offsets_mm": offsets.tolist(),
                "rim_z_mm": (self.z_start_mm - offsets).tolist(),
                "rim_times_s": (self.pre_s + offsets[passed] / self.speed_mm_s).tolist(),
                "rims_passed": int(passed.sum()),
                "slide_start_s": self.pre_s,
                "slide_end_s": self.pre_s + self.slide_mm / self.speed_mm_s}

    def forces(self, t: np.ndarray) -> Forces:
        t = np.atleast_1d(np.asarray(t, float))
        s = (t - self.pre_s) * self.speed_mm_s
        sliding = (s >= 0) & (s <= self.slide_mm)
        mag = np.where(sliding, self.normal_n, 0.0)
        offsets, strength = self._rims
        for off, a in zip(offsets, strength, strict=True):
            u = (s - off) / self.rim_width_mm
            bump = np.where((u >= 0) & (u <= 1), 0.5 - 0.5 * np.cos(2 * np.pi * u), 0.0)
            mag = mag + np.where(sliding, 0.3 * a * bump, 0.0)
        return Forces.polar(mag, 0.0, 0.0, CUP_WALL.friction * mag)

    def excitation(self, n: int, fs: int) -> list[Excitation]:
        ev = self.events()
        offsets, strength = self._rims
        rng = self.rng(1)
        i0 = int(round(self.pre_s * fs))
        m = max(0, min(n - i0, int(round(self.slide_mm / self.speed_mm_s * fs))))
        f = np.zeros(n)
        if m > 0:
            wall, _ = slide_excitation(CUP_WALL, self.speed_mm_s, self.normal_n, m, fs, rng)
            # The nail scrapes harder while it rides over each rolled lip.
            s = np.arange(m) / fs * self.speed_mm_s
            boost = np.ones(m)
            for off in offsets:
                boost += 3.0 * ((s >= off) & (s <= off + self.rim_width_mm))
            f[i0:i0 + m] = wall * boost
        passed = offsets < self.slide_mm
        t_catch = np.asarray(ev["rim_times_s"])
        a = 0.25 * strength[passed] * (self.speed_mm_s / 10.0) ** 0.5
        f += _transient(n, fs, t_catch, a, 2.5e-4)
        t_snap = t_catch + self.rim_width_mm / self.speed_mm_s
        f += _transient(n, fs, t_snap, -0.6 * a, 4e-4)
        # Chatter: the nail sticks and slips a few times while it rides over the lip.
        counts = rng.poisson(6, len(t_catch))
        tc = np.concatenate([rng.uniform(c, s_, k) for c, s_, k in zip(t_catch, t_snap, counts,
                                                                       strict=True)])
        ac = np.repeat(0.3 * a, counts) * np.exp(0.4 * rng.standard_normal(counts.sum()))
        ac *= rng.choice([-1.0, 1.0], len(ac))
        f += _transient(n, fs, tc, ac, 3e-4)
        return [Excitation(f)]


BOX_CONTENTS = ("screws", "rubber_bands", "empty")


@dataclass(frozen=True)
class BoxShake(Scene):
    """Shaking a box held by two nails pressed on its sides (the paper: 0.67 Hz, 5 cm, 5.6 s).

    Contents slide and hit the walls around each turnaround: screws give hard impacts that
    ring (metal), rubber bands soft thuds, an empty box only the grip's faint creak.
    """

    content: str = "screws"
    frequency_hz: float = 0.67
    amplitude_m: float = 0.05
    duration: float = 5.6
    grip_n: float = 1.5
    items: int | None = None
    signals: tuple[str, ...] | None = None
    seed: int = 0
    default_signals: ClassVar[tuple[str, ...]] = (VIBRATION,)

    def __post_init__(self) -> None:
        if self.content not in BOX_CONTENTS:
            raise ValueError(f"content must be one of {BOX_CONTENTS}, not {self.content!r}")

    @property
    def duration_s(self) -> float:
        return self.duration

    @property
    def n_items(self) -> int:
        if self.items is not None:
            return self.items
        return {"screws": 8, "rubber_bands": 10, "empty": 0}[self.content]

    def position_m(self, t: np.ndarray) -> np.ndarray:
        return self.amplitude_m * np.sin(2 * np.pi * self.frequency_hz * np.asarray(t, float))

    def acceleration(self, t: np.ndarray) -> np.ndarray:
        w = 2 * np.pi * self.frequency_hz
        return -self.amplitude_m * w ** 2 * np.sin(w * np.asarray(t, float))

    @cached_property
    def _impacts(self) -> dict[str, np.ndarray]:
        rng = self.rng(0)
        half = 0.5 / self.frequency_hz
        turns = np.arange(0.25 / self.frequency_hz, self.duration, half)
        peak_v = self.amplitude_m * 2 * np.pi * self.frequency_hz
        times, speeds, item = [], [], []
        for tk in turns:
            for i in range(self.n_items):
                # An item leaves the far wall when the box decelerates and lands before the
                # turnaround; a rebound or two follow (restitution ~0.3).
                t_hit = tk - rng.uniform(0.02, 0.3)
                v = peak_v * rng.uniform(0.3, 1.0)
                for _ in range(1 + int(rng.integers(0, 3))):
                    if 0 <= t_hit < self.duration:
                        times.append(t_hit)
                        speeds.append(v)
                        item.append(i)
                    t_hit += rng.uniform(0.005, 0.03)
                    v *= 0.3
        return {"turns": turns, "times": np.asarray(times), "speeds": np.asarray(speeds),
                "item": np.asarray(item, dtype=int)}

    def events(self) -> dict[str, Any]:
        imp = self._impacts
        order = np.argsort(imp["times"])
        return {"content": self.content, "turnaround_times_s": imp["turns"].tolist(),
                "impact_times_s": imp["times"][order].tolist()}

    def forces(self, t: np.ndarray) -> Forces:
        t = np.atleast_1d(np.asarray(t, float))
        box_kg = 0.1 + 0.005 * self.n_items
        mag = self.grip_n + 0.5 * box_kg * self.acceleration(t)
        mag = np.where((t >= 0) & (t <= self.duration), mag, 0.0)
        return Forces.polar(mag, 0.0, 0.0)

    def excitation(self, n: int, fs: int) -> list[Excitation]:
        imp = self._impacts
        rng = self.rng(1)
        t = np.arange(n) / fs
        grip = (self.grip_n / 1.5) ** 0.7
        # The grip creaks faintly where the box accelerates most (all contents, and empty).
        creak = smooth_noise(n, fs, 4000.0, rng) * 2e-4 * grip \
            * (np.abs(self.acceleration(t)) / (self.amplitude_m * (2 * np.pi
                                                                   * self.frequency_hz) ** 2))
        f = creak
        times, speeds = imp["times"], imp["speeds"]
        modes: tuple = ((380.0, 0.12, 0.6), (950.0, 0.1, 0.3))  # cardboard box walls
        lowpass = 9000.0
        if self.content == "screws" and len(times):
            mass = 0.002
            pulse = math.pi * mass * speeds / (2 * 2.5e-4) * 0.08 * grip
            f = f + place(n, times, pulse, half_sine(2.5e-4, fs), fs)
            # Each screw rings at its own frequencies (steel: very light damping).
            k = self.n_items
            ring_f = rng.uniform(3500, 11000, (k, 2))
            length = int(0.06 * fs)
            kern = damped_sine(ring_f[imp["item"], 0], np.full(len(times), 0.004), fs, length) \
                + 0.6 * damped_sine(ring_f[imp["item"], 1], np.full(len(times), 0.004), fs,
                                    length)
            f = f + place(n, times, 0.25 * pulse, kern, fs)
            # Rattle: screws rolling on the floor of the box between impacts.
            rate = 40.0 * k / 8
            count = rng.poisson(rate * self.duration)
            tr = rng.uniform(0, self.duration, count)
            ar = 0.004 * grip * np.exp(0.5 * rng.standard_normal(count))
            f = f + place(n, tr, ar, half_sine(1.5e-4, fs), fs)
        elif self.content == "rubber_bands" and len(times):
            mass = 0.001
            dur = rng.uniform(4e-3, 8e-3)
            pulse = math.pi * mass * speeds / (2 * dur) * 0.08 * grip
            f = f + place(n, times, pulse, half_sine(dur, fs), fs)
            lowpass = 2500.0
        return [Excitation(f, 0, lowpass, modes)]


@dataclass(frozen=True)
class CustomForce(Scene):
    """Forces from a function: ``fn(t) -> Forces`` or ``(fx, fy, height_mm)`` arrays."""

    fn: Callable[[np.ndarray], Any] = field(default=lambda t: Forces.zeros(len(t)))
    duration: float = 1.0
    signals: tuple[str, ...] | None = None
    seed: int = 0

    @property
    def duration_s(self) -> float:
        return self.duration

    def forces(self, t: np.ndarray) -> Forces:
        t = np.atleast_1d(np.asarray(t, float))
        out = self.fn(t)
        if isinstance(out, Forces):
            return out
        fx, fy, h = (np.broadcast_to(np.asarray(v, float), t.shape) for v in out)
        return Forces(np.stack([fx, fy], axis=1), h.copy(), np.zeros(t.shape))


@dataclass(frozen=True)
class Script(Scene):
    """Scenes one after another (``gap_s`` of idle between them). It needs the union of its
    parts' signals; each part contributes only the signals it needs itself."""

    parts: tuple[Scene, ...] = ()
    gap_s: float = 0.0
    signals: tuple[str, ...] | None = None
    seed: int = 0

    @property
    def needs(self) -> frozenset[str]:
        if self.signals is not None:
            return super().needs
        return frozenset().union(*(p.needs for p in self.parts)) if self.parts \
            else frozenset()

    @property
    def offsets_s(self) -> np.ndarray:
        d = [p.duration_s + self.gap_s for p in self.parts]
        return np.concatenate([[0.0], np.cumsum(d)[:-1]]) if d else np.zeros(0)

    @property
    def duration_s(self) -> float:
        return float(sum(p.duration_s for p in self.parts) + self.gap_s
                     * max(0, len(self.parts) - 1))

    def forces(self, t: np.ndarray) -> Forces:
        t = np.atleast_1d(np.asarray(t, float))
        out = Forces.zeros(len(t))
        for off, part in zip(self.offsets_s, self.parts, strict=True):
            if FORCE not in part.needs:
                continue
            sel = (t >= off) & (t < off + part.duration_s)
            if sel.any():
                f = part.forces(t[sel] - off)
                out.xy[sel], out.height_mm[sel], out.z[sel] = f.xy, f.height_mm, f.z
        return out

    def excitation(self, n: int, fs: int) -> list[Excitation]:
        out = []
        for off, part in zip(self.offsets_s, self.parts, strict=True):
            if VIBRATION not in part.needs:
                continue
            i0 = int(round(off * fs))
            m = min(n - i0, int(round(part.duration_s * fs)))
            if m <= 0:
                continue
            for seg in part.excitation(m, fs):
                out.append(Excitation(seg.force[:max(0, m - seg.start)], seg.start + i0,
                                      seg.lowpass_hz, seg.modes))
        return out

    def events(self) -> dict[str, Any]:
        parts = []
        for off, part in zip(self.offsets_s, self.parts, strict=True):
            ev = {}
            for k, v in part.events().items():
                if k.endswith("_s"):
                    v = [x + off for x in v] if isinstance(v, list) else v + off
                ev[k] = v
            parts.append({"scene": part.name, "start_s": float(off),
                          "end_s": float(off + part.duration_s), "events": ev})
        return {"parts": parts}
