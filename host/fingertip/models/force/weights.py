"""Calibration with known weights, for labs without a force/torque sensor.

The fingertip is turned so that a weight hung from its nail (or placed on it) pulls along
one of its axes; the user enters each mass. Per direction at least three masses; every
step is recorded once settled, and becomes a trial of rows whose reference force is
m * g along that direction. The rows go to the same fitting as every other calibration
(:func:`.calibrate.fit_calibration`, whole steps held out for the RMSE).
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from ...errors import EXIT_FAILED
from .calibrate import CHANNELS, CalibrationData, CalibrationError, from_arrays

G = 9.80665
DIRECTIONS = {"+X": 0.0, "+Y": 90.0, "-X": 180.0, "-Y": 270.0}
"""Direction of the force on the fingertip, degrees from +x."""
MIN_MASSES = 3
SETTLE_S = 0.8
RECORD_S = 1.5


class WeightsError(CalibrationError):
    code = "weights"


@dataclass
class WeightStep:
    direction: str
    mass_g: float
    counts: np.ndarray
    """(N, 4) tared counts recorded while the weight hung still."""

    @property
    def force(self) -> np.ndarray:
        f = self.mass_g * 1e-3 * G
        a = math.radians(DIRECTIONS[self.direction])
        return np.array([f * math.cos(a), f * math.sin(a)])


@dataclass
class WeightsSession:
    steps: list[WeightStep] = field(default_factory=list)

    def check(self, min_masses: int = MIN_MASSES) -> None:
        """Raise :class:`WeightsError` unless every direction used has enough masses and
        both axes are covered."""
        by: dict[str, set[float]] = {}
        for s in self.steps:
            if s.mass_g > 0:
                by.setdefault(s.direction, set()).add(s.mass_g)
        short = {d: len(m) for d, m in by.items() if len(m) < min_masses}
        if short or not by:
            have = ", ".join(f"{d}: {n}" for d, n in short.items()) or "none"
            raise WeightsError(f"need at least {min_masses} different masses per direction "
                               f"(have {have})")
        axes = {DIRECTIONS[d] % 180 for d in by}
        if len(axes) < 2:
            raise WeightsError("weights along one axis only: the other axis is not "
                               "determined; hang weights along X and along Y")

    def dataset(self, gain: int = 128, unit: str = "") -> CalibrationData:
        self.check()
        counts = np.concatenate([s.counts for s in self.steps])
        force = np.concatenate([np.tile(s.force, (len(s.counts), 1)) for s in self.steps])
        trial = np.concatenate([np.full(len(s.counts), k) for k, s in enumerate(self.steps)])
        return from_arrays(counts.reshape(-1, CHANNELS), force[:, 0], force[:, 1], trial=trial,
                           gain=gain, sources=("known weights",), unit=unit)


class WeightsGuide(Protocol):
    def place(self, direction: str, index: int) -> float | None:
        """Have the next weight hung along ``direction``; return its mass in grams, or None
        when this direction is done."""

    def remove(self) -> None:
        """Have every weight taken off."""


def parse_mass(text: str) -> float | None:
    """'' -> None (done); '100', '100 g', '0.1 kg' -> grams; ValueError otherwise."""
    t = text.strip().lower().replace(" ", "")
    if not t:
        return None
    scale = 1000.0 if t.endswith("kg") else 1.0
    t = t.removesuffix("kg").removesuffix("g")
    v = float(t) * scale
    if not (v > 0 and math.isfinite(v)):
        raise ValueError("a mass must be a positive number of grams")
    return v


class PromptWeightsGuide:
    """Asks on the terminal."""

    def __init__(self, ask: Callable[[str], str] = input) -> None:
        self.ask = ask

    def place(self, direction: str, index: int) -> float | None:
        while True:
            try:
                text = self.ask(f"Turn the fingertip so the weight pulls it along {direction}. "
                                f"Hang weight #{index + 1}, let it settle, and enter its mass "
                                "in g (Enter alone: next direction): ")
            except EOFError:
                return None
            try:
                return parse_mass(text)
            except ValueError as e:
                print(f"  {e}; again")

    def remove(self) -> None:
        try:
            self.ask("Take every weight off and press Enter: ")
        except EOFError:
            pass


def record_weights(ft, guide: WeightsGuide, directions: Sequence[str] = tuple(DIRECTIONS),
                   *, settle_s: float = SETTLE_S, record_s: float = RECORD_S,
                   say: Callable[[str], None] | None = None) -> WeightsSession:
    """Tare, then for each direction the masses the guide places: wait ``settle_s``,
    record ``record_s`` (device time) of frames without timeouts or saturation."""
    say = say or (lambda _m: None)
    ft.tare(samples=16)
    ft.start()
    session = WeightsSession()
    try:
        session.steps.append(WeightStep("+X", 0.0, _capture(ft, settle_s, record_s)))
        for d in directions:
            k = 0
            while True:
                m = guide.place(d, k)
                if m is None:
                    break
                step = WeightStep(d, m, _capture(ft, settle_s, record_s))
                session.steps.append(step)
                say(f"{d}: {m:g} g = {m * 1e-3 * G:.3f} N, {len(step.counts)} readings")
                k += 1
            guide.remove()
    finally:
        ft.stop()
    return session


def _capture(ft, settle_s: float, record_s: float) -> np.ndarray:
    ft.drain()
    rows, t0 = [], None
    while True:
        f = ft.read(timeout=2.0)
        if f is None:
            # it streamed, then stopped: a failure at run time (1), not the data's fault
            raise WeightsError("the fingertip stopped streaming", exit_code=EXIT_FAILED)
        t = f.device_time_us * 1e-6
        t0 = t if t0 is None else t0
        if t - t0 < settle_s:
            continue
        if f.ok:
            rows.append(f.counts[:CHANNELS])
        if t - t0 >= settle_s + record_s:
            return np.array(rows, float).reshape(-1, CHANNELS)
