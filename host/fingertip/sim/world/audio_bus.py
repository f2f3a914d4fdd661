"""The simulated fingertips' contact microphones, rendered only where a scene needs them.

A scene's excitation (a cup slide, a box shake) is filtered once, when the world starts the
motion that causes it, into preamp-input volts placed at its start sample
(:meth:`AudioBus.add`). :meth:`AudioBus.read` then gives each finger the samples since its
previous read: the sum of that finger's sources over those samples, through the rest of the
audio chain (noise, mains hum by absolute sample index, preamp gain, clipping, the sound
card's quantisation), which works sample by sample, so blocks of any size join seamlessly.
Nothing is computed for a finger nobody listens to.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..physics import AudioChain, Scene
from ...tasks.interfaces import AudioBlock


@dataclass
class _Source:
    finger: str
    start: int
    volts: np.ndarray


class AudioBus:
    """Audio of every fingertip of a simulated hand on the world's clock (sample i is at
    ``i / fs`` seconds)."""

    def __init__(self, chain: AudioChain, rng: np.random.Generator) -> None:
        self.chain = chain
        self.fs = chain.fs
        self.rng = rng
        self._sources: list[_Source] = []
        self._cursor: dict[str, int] = {}

    def add(self, scene: Scene, t_start: float, duration_s: float,
            fingers: tuple[str, ...]) -> None:
        """Render ``scene``'s excitation for ``duration_s`` (plus the filters' ringing) with
        its time 0 at world time ``t_start``, heard by ``fingers``."""
        n = int(round(duration_s * self.fs)) + self.chain.pad
        volts = self.chain.filter(scene.excitation(n, self.fs), n)
        start = int(round(t_start * self.fs))
        for f in fingers:
            self._sources.append(_Source(f, start, volts))

    def read(self, finger: str, t_now: float) -> AudioBlock:
        end = int(np.floor(t_now * self.fs))
        start = self._cursor.get(finger, end)
        self._cursor[finger] = max(start, end)
        n = max(0, end - start)
        v = np.zeros(n)
        for s in self._sources:
            if s.finger != finger:
                continue
            a, b = max(start, s.start), min(end, s.start + len(s.volts))
            if a < b:
                v[a - start:b - start] += s.volts[a - s.start:b - s.start]
        # Forget sources that are over for every finger (long experiments stay small).
        low = min(self._cursor.values())
        self._sources = [s for s in self._sources if s.start + len(s.volts) > low]
        samples = self.chain.finish(v, start, self.rng).samples if n else np.zeros(0, np.float32)
        return AudioBlock(samples, float(self.fs), start / self.fs)
