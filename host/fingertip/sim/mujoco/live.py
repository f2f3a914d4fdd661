"""A MuJoCo scene running behind the virtual device: its counts feed the firmware's C++ core
(:class:`VirtualFirmware`, served on a pty by ``fingertip sim mujoco``), its piezo feeds a
capture source (:class:`~fingertip.audio.SimulatedSource`), so ``fingertip stream``,
``record``, ``check`` and ``publish`` read a simulated robot as they read a fingertip.

The simulation runs on demand: the device asks for the chips' inputs at its conversion times
and the audio source for its blocks' samples, and the scene steps until it covers the later
of the two (both may come from different threads: one lock). The scene's motion repeats: a
press and a slide over the seven plates, or a pinch of the tofu.
"""
from __future__ import annotations

import math
import threading
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ._require import mujoco
from .drive import press_and_slide
from .gripper import gripper
from .project import PAPER_SEVEN, SimulatedSource
from .scenes import PLATE_PITCH, Scene, probe
from .sensor import FingertipSensor


@dataclass(frozen=True)
class LiveScene:
    build: Callable[[], Scene]
    tip: str
    control: Callable[[float, object], None]
    """Sets the controls for the simulation time (the motion repeats)."""
    what: str


def _slide_control(t: float, data) -> None:
    """Every 4 s: press 1 N on a plate, slide 48 mm over it at 20 mm/s, lift, go to the next
    plate (the seven in turn)."""
    cycle, k = math.modf(t / 4.0)
    plate = int(k) % len(PAPER_SEVEN)
    u = cycle * 4.0
    lift = u > 3.4
    press_and_slide(slide_mm_s=20.0, t_press=0.6, t_slide=1.0)(0.0 if lift else u, data)
    start = plate * PLATE_PITCH - 0.024
    end = start + 0.02 * 2.4
    if lift:  # lifted: over to the next plate's start
        nxt = (plate + 1) % len(PAPER_SEVEN) * PLATE_PITCH - 0.024
        data.ctrl[0] = end + (nxt - end) * (u - 3.4) / 0.6
    else:
        data.ctrl[0] = start + 0.02 * max(0.0, u - 1.0)


def _pinch_control(t: float, data) -> None:
    """Down beside the tofu once; then every 6 s: close to about 1 N, lift 20 mm, put it
    down, open."""
    u = t % 6.0
    lift = 0.02 * (min(1.0, max(0.0, u - 2.5)) - min(1.0, max(0.0, u - 4.0)))
    data.ctrl[2] = -0.096 * min(1.0, t / 0.5) + lift
    data.ctrl[3] = data.ctrl[4] = 0.0234 * min(1.0, max(0.0, u - 0.8)) if u < 5.2 else 0.0


SCENES = {
    "slide": LiveScene(lambda: probe(), "tip", _slide_control,
                       "a probe presses and slides over the paper's seven materials"),
    "pinch": LiveScene(lambda: gripper(("tofu",)), "left", _pinch_control,
                       "a gripper pinches the tofu, lifts it and puts it down"),
}


class LiveSimulation:
    """One fingertip of a scene, stepped on demand for the device and the microphone."""

    def __init__(self, name: str, seed: int = 0, *, keep: bool = False) -> None:
        """``keep``: also keep every reading in :attr:`history` (for a run's summary)."""
        if name not in SCENES:
            raise ValueError(f"unknown scene {name!r}: one of {', '.join(SCENES)}")
        self.spec = SCENES[name]
        self.scene = self.spec.build()
        self.m, self.d = self.scene.model, self.scene.data
        self.sensor = FingertipSensor(self.m, self.d, self.scene.tips[self.spec.tip],
                                      fidelity="full", seed=seed, batch=1,
                                      materials=self.scene.materials)
        self.breakables = self.scene.info.get("breakables")
        self._lock = threading.Lock()
        self._raw = np.zeros(4)
        self._audio: list[np.ndarray] = []
        self._audio_start = 0
        self._audio_len = 0
        self.keep = keep
        self.history: list = []

    def advance_to(self, t_s: float) -> None:
        """Step the scene until its time reaches ``t_s`` (s)."""
        mj = mujoco()
        with self._lock:
            while self.d.time < t_s:
                self.spec.control(self.d.time, self.d)
                mj.mj_step(self.m, self.d)
                self.sensor.step()
                if self.breakables is not None:
                    self.breakables.update(self.d)
                rs = self.sensor.readings()
                if rs:
                    self._raw = rs[-1].raw
                    if self.keep:
                        self.history += rs
                for b in self.sensor.audio():
                    self._audio.append(b.samples)
                    self._audio_len += len(b.samples)

    def counts_source(self) -> Callable[[int], tuple[float, ...]]:
        """The ``source`` of :class:`VirtualFirmware`: device time (us) -> the four chips'
        inputs (counts at gain 128, unrounded), the scene's latest conversion."""
        def source(t_us: int) -> tuple[float, ...]:
            self.advance_to(t_us * 1e-6)
            return tuple(float(v) for v in self._raw)
        return source

    def audio_so_far(self) -> np.ndarray:
        """Every piezo sample kept so far (from the first one not yet read by a source)."""
        with self._lock:
            return np.concatenate(self._audio) if self._audio else np.zeros(0, np.float32)

    def samples(self, first: int, n: int) -> np.ndarray:
        """Piezo samples ``first .. first + n`` (simulating as far as they need)."""
        fs = self.sensor.piezo.fs
        block = self.sensor.piezo.block
        while self._audio_start + self._audio_len < first + n:
            self.advance_to(self.d.time + block / fs)
        with self._lock:
            x = np.concatenate(self._audio) if len(self._audio) > 1 else self._audio[0]
            # Keep from ``first`` on: a capture source never reads backwards.
            drop = max(0, first - self._audio_start)
            x = x[drop:]
            self._audio, self._audio_start, self._audio_len = [x], self._audio_start + drop, \
                len(x)
            k = first - self._audio_start
            return x[k:k + n]

    def audio_source(self, realtime: bool = True,
                     duration: float | None = None) -> SimulatedSource:
        """The piezo as a capture source (the interface every simulated microphone uses)."""
        fs = self.sensor.piezo.fs

        def func(t: np.ndarray) -> np.ndarray:
            first = int(round(t[0] * fs))
            return self.samples(first, len(t))

        return SimulatedSource(func, fs, realtime=realtime, duration=duration,
                               name=f"MuJoCo {self.spec.tip} piezo")
