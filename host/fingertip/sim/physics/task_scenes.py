"""The paper's task scenes: the nail sliding over a stack of cups (counting rims) and a
box shaken between two nails (its contents). See :mod:`.scenes` for what a scene is."""
from __future__ import annotations


import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any, ClassVar

import numpy as np

from .materials import CUP_WALL
from .vibration import (
    Excitation,
    damped_sine,
    half_sine,
    place,
    slide_excitation,
    smooth_noise,
)

from .scenes import VIBRATION, Forces, Scene, _transient


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

# How a box's contents sound at a nail pressed on its wall, shared with the MuJoCo boxes
# (``sim/mujoco/box_sound.py``), whose impacts come from the physics instead of a script.
ITEM_MASS_KG = {"screws": 0.002, "rubber_bands": 0.001}
BOX_WALL_MODES = ((380.0, 0.12, 0.6), (950.0, 0.1, 0.3))
"""Cardboard box walls between the contents and the nail (Hz, damping, weight)."""
BOX_LOWPASS_HZ = {"screws": 9000.0, "rubber_bands": 2500.0, "empty": 9000.0}
WALL_TO_NAIL = 0.08
"""Share of an item's impact force on the wall that reaches the nail (at a 1.5 N grip)."""
SCREW_PULSE_S = 2.5e-4
BAND_PULSE_S = (4e-3, 8e-3)
"""A rubber band's thud lasts this long (one duration drawn per shake)."""
SCREW_RING_HZ = (3500.0, 11000.0)
"""Each screw rings at two frequencies drawn in this range (steel: very light damping)."""
SCREW_RING_ZETA = 0.004
SCREW_RING_S = 0.06
SCREW_RING_GAIN = (0.25, 0.6)
"""The ring's share of the impact pulse, and its second mode's share of the first."""
RATTLE_PULSE_S = 1.5e-4
RATTLE_N = 0.004
"""A screw rolling on the box's floor: ticks of this size (x grip, log-normal spread 0.5)."""
CREAK_N = 2e-4
"""The grip's faint creak at the box's peak acceleration (x grip)."""


def grip_transmission(grip_n: float) -> float:
    """How a nail's grip force scales what it hears through the wall (1 at 1.5 N)."""
    return (grip_n / 1.5) ** 0.7


def impact_pulse_n(content: str, speeds: np.ndarray, duration_s: float,
                   grip: float) -> np.ndarray:
    """Peak force at the nail of items hitting the wall at ``speeds`` (m/s): the item's
    momentum delivered over a half sine of ``duration_s``, times the wall's transmission."""
    return math.pi * ITEM_MASS_KG[content] * speeds / (2 * duration_s) * WALL_TO_NAIL * grip


def screw_ring(ring_hz: np.ndarray, fs: int) -> np.ndarray:
    """Ring kernels of screws with two modes each (``ring_hz`` (M, 2)), unit first mode."""
    length = int(SCREW_RING_S * fs)
    m = len(ring_hz)
    return damped_sine(ring_hz[:, 0], np.full(m, SCREW_RING_ZETA), fs, length) \
        + SCREW_RING_GAIN[1] * damped_sine(ring_hz[:, 1], np.full(m, SCREW_RING_ZETA), fs,
                                           length)


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
        grip = grip_transmission(self.grip_n)
        # The grip creaks faintly where the box accelerates most (all contents, and empty).
        creak = smooth_noise(n, fs, 4000.0, rng) * CREAK_N * grip \
            * (np.abs(self.acceleration(t)) / (self.amplitude_m * (2 * np.pi
                                                                   * self.frequency_hz) ** 2))
        f = creak
        times, speeds = imp["times"], imp["speeds"]
        modes: tuple = BOX_WALL_MODES
        lowpass = BOX_LOWPASS_HZ["screws"]
        if self.content == "screws" and len(times):
            pulse = impact_pulse_n("screws", speeds, SCREW_PULSE_S, grip)
            f = f + place(n, times, pulse, half_sine(SCREW_PULSE_S, fs), fs)
            k = self.n_items
            ring_f = rng.uniform(*SCREW_RING_HZ, (k, 2))
            f = f + place(n, times, SCREW_RING_GAIN[0] * pulse,
                          screw_ring(ring_f[imp["item"]], fs), fs)
            # Rattle: screws rolling on the floor of the box between impacts.
            rate = 40.0 * k / 8
            count = rng.poisson(rate * self.duration)
            tr = rng.uniform(0, self.duration, count)
            ar = RATTLE_N * grip * np.exp(0.5 * rng.standard_normal(count))
            f = f + place(n, tr, ar, half_sine(RATTLE_PULSE_S, fs), fs)
        elif self.content == "rubber_bands" and len(times):
            dur = rng.uniform(*BAND_PULSE_S)
            pulse = impact_pulse_n("rubber_bands", speeds, dur, grip)
            f = f + place(n, times, pulse, half_sine(dur, fs), fs)
            lowpass = BOX_LOWPASS_HZ["rubber_bands"]
        return [Excitation(f, 0, lowpass, modes)]
