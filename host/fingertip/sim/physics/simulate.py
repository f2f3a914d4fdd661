"""Run a scene: force-channel counts at the HX711 rate and/or audio at 44.1 kHz.

Only the signals the scene needs are computed (``scene.needs``): a press never touches the
vibration synthesis, a slide never touches the strain model.

Time bases: device time ``t0_us`` is scene time 0. Force conversions happen at
``t0_us + k * period_us`` for k = 1, 2, ... (as the firmware's first conversion comes one
period after boot), stamped in device microseconds. Audio sample i is at scene time i / fs,
that is device time ``t0_us + i * 1e6 / fs``.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import vibration
from .scenes import FORCE, VIBRATION, Scene
from .strain import VirtualStrainSensor
from .vibration import AudioChain


@dataclass
class ForceTrace:
    t_us: np.ndarray
    """(N,) int64 device timestamps of the conversions."""
    counts: np.ndarray
    """(N, 4) int64 HX711 counts (gain 128), rounded and saturated."""
    fx: np.ndarray
    fy: np.ndarray
    fz: np.ndarray
    height_mm: np.ndarray
    rate_sps: int

    @property
    def saturated(self) -> np.ndarray:
        return (self.counts >= 2 ** 23 - 1) | (self.counts <= -(2 ** 23))


@dataclass
class AudioTrace:
    samples: np.ndarray
    """float32, normalised: 1.0 = the sound card's full scale."""
    fs: int
    t0_us: int
    start_index: int = 0
    clipped_fraction: float = 0.0
    """Samples at the sound card's limits (includes preamp rail clipping)."""
    preamp_gain: float = 0.0
    rail_clipped: int = 0
    """Samples where the preamp's output hit its rails."""

    @property
    def index(self) -> np.ndarray:
        """Sample indices (sample 0 = scene time 0)."""
        return self.start_index + np.arange(len(self.samples), dtype=np.int64)

    @property
    def t_us(self) -> np.ndarray:
        return self.t0_us + self.index * (1e6 / self.fs)


@dataclass
class SimResult:
    scene: Scene
    duration_s: float
    force: ForceTrace | None
    audio: AudioTrace | None
    events: dict[str, Any]
    wall_s: dict[str, float] = field(default_factory=dict)

    @property
    def realtime_factor(self) -> float:
        """Simulated seconds per wall second for this run."""
        wall = sum(self.wall_s.values())
        return self.duration_s / wall if wall > 0 else float("inf")


def force_trace(scene: Scene, duration_s: float, sensor: VirtualStrainSensor,
                t0_us: int = 0) -> ForceTrace:
    period = 1_000_000 // sensor.rate_sps
    n = int(duration_s * 1e6 // period)
    t_us = t0_us + period * (1 + np.arange(n, dtype=np.int64))
    ts = (t_us - t0_us) * 1e-6
    f = scene.forces(ts)
    counts = sensor.counts_batch(f.xy, f.height_mm, t_us * 1e-6, f.z)
    return ForceTrace(t_us, counts, f.xy[:, 0].copy(), f.xy[:, 1].copy(), f.z, f.height_mm,
                      sensor.rate_sps)


def simulate(scene: Scene, duration: float | None = None, *, seed: int = 0,
             sensor: VirtualStrainSensor | None = None, rate_sps: int = 80, t0_us: int = 0,
             chain: AudioChain | None = None, preamp_gain: float | None = None,
             hum: bool = True, mains_hz: float | None = None) -> SimResult:
    """Simulate ``scene`` for ``duration`` s (default: the scene's own duration).

    ``sensor``: the virtual fingertip (default: unit ``seed`` at ``rate_sps``); it keeps its
    state (hysteresis, creep) across calls, so give later calls a later ``t0_us``.
    ``seed`` also seeds the audio noise; the scene's own realisation comes from its ``seed``.
    ``chain`` (or ``preamp_gain``, ``hum``, ``mains_hz``) sets up the audio path.
    """
    duration = scene.duration_s if duration is None else float(duration)
    needs = scene.needs
    wall: dict[str, float] = {}
    force = audio = None
    if FORCE in needs:
        w0 = time.perf_counter()
        if sensor is None:
            sensor = VirtualStrainSensor(seed, rate_sps=rate_sps)
        force = force_trace(scene, duration, sensor, t0_us)
        wall[FORCE] = time.perf_counter() - w0
    if VIBRATION in needs:
        w0 = time.perf_counter()
        if chain is None:
            chain = AudioChain(preamp_gain=preamp_gain, hum=hum, mains_hz=mains_hz)
        n = int(round(duration * chain.fs))
        rng = np.random.default_rng(np.random.SeedSequence([seed, 0xA0D10]))
        res = vibration.render(scene, n, chain, rng)
        audio = AudioTrace(res.samples, chain.fs, t0_us, 0, res.clipped_fraction,
                           res.preamp_gain, res.extra["rail_clipped"])
        wall[VIBRATION] = time.perf_counter() - w0
    return SimResult(scene, duration, force, audio, scene.events(), wall)
