"""A virtual fingertip on the bench: a unit (with build faults) whose presses and taps the
simulator applies when ``fingertip check`` asks a person to press.

:class:`GuidedScene` is a scene driven while it runs: :meth:`~GuidedScene.press` and
:meth:`~GuidedScene.tap` schedule loads at device times. :class:`VirtualUnit` ties it to a
:class:`VirtualStrainSensor`, the firmware twin (faults applied) and the piezo chain, and
:class:`SimGuide` is the check's guide that performs the steps on it.
"""
from __future__ import annotations

import math
import threading
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .faults import Fault, audio_settings, dead_mask, loosen, wrap_source
from ..physics import AudioChain, Excitation, Forces, VirtualStrainSensor
from ..physics.vibration import half_sine, place
from .virtual_firmware import VirtualFirmware

PRESS_N = 2.0
"""Force of a simulated guided press (a firm finger push)."""
TAP_N = 1.0
TAP_IMPACT_N = 0.1
"""Peak of the impact the piezo hears (a light tap with a fingertip: well below clipping)."""


@dataclass(frozen=True)
class _Load:
    t0: float
    angle_deg: float
    peak_n: float
    ramp_s: float
    hold_s: float
    height_mm: float

    def magnitude(self, t: np.ndarray) -> np.ndarray:
        k = [self.t0, self.t0 + self.ramp_s, self.t0 + self.ramp_s + self.hold_s,
             self.t0 + 2 * self.ramp_s + self.hold_s]
        return np.interp(t, k, [0.0, self.peak_n, self.peak_n, 0.0], left=0.0, right=0.0)


class GuidedScene:
    """Loads added while the scene runs (times in seconds of device time)."""

    def __init__(self) -> None:
        self._loads: list[_Load] = []
        self._taps: list[float] = []
        self._lock = threading.Lock()

    def press(self, t0: float, angle_deg: float, peak_n: float = PRESS_N, ramp_s: float = 0.25,
              hold_s: float = 0.8, height_mm: float = 2.0) -> float:
        """Schedule a press; returns when it ends."""
        with self._lock:
            self._loads.append(_Load(t0, angle_deg, peak_n, ramp_s, hold_s, height_mm))
        return t0 + 2 * ramp_s + hold_s

    def tap(self, times: Sequence[float], peak_n: float = TAP_N) -> None:
        """Short taps on the nail (10 ms), felt by the gauges and heard by the piezo."""
        with self._lock:
            self._taps.extend(times)
            for t in times:
                self._loads.append(_Load(t, 90.0, peak_n, 0.02, 0.02, 0.0))

    def forces(self, t: np.ndarray) -> Forces:
        t = np.atleast_1d(np.asarray(t, float))
        with self._lock:
            loads = list(self._loads)
        xy = np.zeros((len(t), 2))
        height = np.zeros(len(t))
        for ld in loads:
            m = ld.magnitude(t)
            a = math.radians(ld.angle_deg)
            xy += m[:, None] * np.array([math.cos(a), math.sin(a)])
            height = np.where(m > 0, ld.height_mm, height)
        return Forces(xy, height, np.zeros(len(t)))

    def tap_times(self) -> list[float]:
        with self._lock:
            return list(self._taps)


class VirtualUnit:
    """One virtual fingertip (seed = unit) with ``faults``: its firmware twin, its scene, its
    piezo. Use :attr:`firmware` in-process or behind a :class:`~.pty_device.PtyDevice`."""

    def __init__(self, seed: int = 0, faults: Sequence[Fault] = (), rate_sps: int = 80) -> None:
        self.seed = seed
        self.faults = list(faults)
        self.scene = GuidedScene()
        self.sensor = VirtualStrainSensor(seed, rate_sps=rate_sps)
        loosen(self.sensor, self.faults)
        source = wrap_source(self.sensor.as_source(self.scene), self.faults,
                             self.sensor.noise_counts_rms(80), seed)
        self.firmware = VirtualFirmware(4, source=source)
        self.firmware.dead_mask = dead_mask(self.faults)
        self.audio = audio_settings(self.faults)
        gain = self.sensor.params.preamp.gain * float(self.audio["gain_factor"])
        self.chain = AudioChain(self.sensor.params, preamp_gain=gain)
        self._audio_rng = np.random.default_rng([seed, 44100])

    @property
    def now_s(self) -> float:
        return self.firmware.now_us * 1e-6

    def render_audio(self, t0: float, t1: float) -> np.ndarray:
        """What the paired sound card records from device time ``t0`` to ``t1`` (float32,
        1.0 = full scale)."""
        fs = self.chain.fs
        n = max(0, int(round((t1 - t0) * fs)))
        start = int(round(t0 * fs))
        taps = np.array([t - t0 for t in self.scene.tap_times() if t0 - 0.1 < t < t1])
        force = place(n, taps, np.full(len(taps), TAP_IMPACT_N), half_sine(0.004, fs), fs)
        v = self.chain.filter([Excitation(force)], n)
        a = self.audio
        if not a["connected"]:
            # Nothing at the card's input but its own noise floor.
            card = 10 ** (self.sensor.params.soundcard.noise_dbfs_rms / 20)
            return (self._audio_rng.standard_normal(n) * card).astype(np.float32)
        if a["hum_factor"] != 1.0:
            v += (a["hum_factor"] - 1.0) * self.chain.hum_wave(start, n)
        return self.chain.finish(v, start, self._audio_rng).samples


class SimGuide:
    """The check's guide for a virtual unit: the simulator applies each guided step.

    ``lead_s``: delay between the request and the load (a person needs a moment too).
    """

    interactive = False
    simulated = True

    def __init__(self, unit: VirtualUnit, lead_s: float = 0.25) -> None:
        self.unit = unit
        self.lead_s = lead_s
        self.acted_at_s: float | None = None
        """Device time when the last step was asked (the check records from there)."""

    def press(self, face: int, label: str) -> bool:
        self.acted_at_s = now = self.unit.now_s
        # Pressing the face whose outward normal is at face*90 deg pushes towards its
        # opposite: the force on the fingertip points at face*90 + 180 deg.
        self.unit.scene.press(now + self.lead_s, face * 90.0 + 180.0)
        return True

    def tap(self, count: int) -> bool:
        self.acted_at_s = now = self.unit.now_s
        t = now + self.lead_s
        self.unit.scene.tap([t + 0.35 * k for k in range(count)])
        return True


class SimAudio:
    """The check's audio capture for a virtual unit (its clock is the device's)."""

    def __init__(self, unit: VirtualUnit) -> None:
        self.unit = unit
        self.sample_rate = float(unit.chain.fs)
        self.name = "virtual piezo"
        self._t0 = 0.0

    def start(self, device_time_s: float) -> None:
        self._t0 = device_time_s

    def stop(self, device_time_s: float) -> tuple[np.ndarray, float]:
        """The recording since :meth:`start` and the device time of its first sample."""
        return self.unit.render_audio(self._t0, device_time_s), self._t0


class SimWeightsGuide:
    """The known-weights procedure on a virtual unit: each mass hangs at the nail along the
    asked direction (a ramp, then held) until :meth:`remove`; ``masses_g`` per direction."""

    def __init__(self, unit: VirtualUnit, masses_g=(50.0, 100.0, 200.0, 300.0)) -> None:
        self.unit = unit
        self.masses = list(masses_g)

    def place(self, direction: str, index: int) -> float | None:
        # The procedure's directions and timing live in the layer above: import at use.
        from ...models.force.weights import DIRECTIONS, RECORD_S, SETTLE_S, G

        if index >= len(self.masses):
            return None
        m = self.masses[index]
        # Held through the procedure's settle and record windows, off before the next.
        self.unit.scene.press(self.unit.now_s, DIRECTIONS[direction], m * 1e-3 * G,
                              ramp_s=0.1, hold_s=SETTLE_S + RECORD_S - 0.05, height_mm=0.0)
        return m

    def remove(self) -> None:
        pass  # each simulated weight comes off by itself after its hold
