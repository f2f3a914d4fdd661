"""A simulated piezo: samples from a function of time, behind the same interface as a card.

The physics simulator plugs in here: ``SimulatedSource(scene.vibration, 44100)``.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .blocks import BlockSource
from .pcm import FULL_SCALE, to_pcm

SignalFunction = Callable[[np.ndarray], np.ndarray]


class SimulatedSource(BlockSource):
    """Frames computed by ``func(t)`` at ``sample_rate``.

    ``func`` receives the times of the block's frames in seconds since frame 0
    (``k / sample_rate``, float64, shape ``(n,)``; a reused buffer: do not keep it) and
    returns ``(n,)`` or ``(n, channels)`` samples: floats in full-scale units (-1.0 .. 1.0;
    converted to the integer dtypes like a sound card does, rounded and clipped), or integers
    already in the source's dtype. ``duration`` (seconds) ends the stream; None runs until
    stopped. ``realtime`` paces like a live card; otherwise blocks are made on demand.
    """

    def __init__(self, func: SignalFunction, sample_rate: float = 44100, channels: int = 1,
                 dtype: str = "float32", *, blocksize: int = 441, realtime: bool = True,
                 duration: float | None = None, buffer_seconds: float = 10.0,
                 host_time0: float | None = None, name: str = "simulated piezo") -> None:
        super().__init__(sample_rate, channels, dtype, blocksize=blocksize, realtime=realtime,
                         buffer_seconds=buffer_seconds, name=name, host_time0=host_time0)
        if duration is not None and duration < 0:
            raise ValueError("duration must not be negative")
        self.func = func
        self.duration = duration
        self.total_frames = None if duration is None else round(duration * self.sample_rate)
        self._t = np.zeros(self.blocksize, dtype=np.float64)
        self._ramp = np.arange(self.blocksize, dtype=np.float64)
        self._f = np.zeros((self.blocksize, self.channels), dtype=np.float64)
        self._out = np.zeros((self.blocksize, self.channels), dtype=self.dtype)
        # Worked out once, not per block (np.issubdtype and np.clip are Python-level and cost
        # more than the block's arithmetic at 100 blocks a second).
        self._integer = self.dtype in FULL_SCALE

    def _open(self) -> None:
        pass

    def _next_block(self, first_index: int, n: int) -> np.ndarray | None:
        if self.total_frames is not None:
            n = min(n, self.total_frames - first_index)
            if n <= 0:
                return None
        t = self._t[:n]
        np.add(self._ramp[:n], first_index, out=t)
        t /= self.sample_rate
        y = np.asarray(self.func(t))
        if y.shape[0] != n or (y.ndim == 2 and y.shape[1] not in (1, self.channels)) \
                or y.ndim not in (1, 2):
            raise ValueError(f"{self.name}: func returned shape {y.shape} for {n} frames "
                             f"of {self.channels} channel(s)")
        if y.ndim == 1:
            y = y.reshape(n, 1)
        out = self._out[:n]
        if self._integer and y.dtype.kind == "f":
            # one channel broadcasts to all; rounded and clipped like a card's converter
            to_pcm(y, self.dtype, out=out, work=self._f[:n])
        else:
            np.copyto(out, y, casting="same_kind" if y.dtype.kind == out.dtype.kind
                      else "unsafe")
        return out
