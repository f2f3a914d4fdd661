"""Base of the sources that make their own blocks (files, simulators): ideal timestamps.

Frame ``k`` has host time ``host_time0 + k / sample_rate`` exactly: the source is its own
ADC (``host_time0`` defaults to the moment of ``start()``; a replay can pass the recording's
own). ``realtime=True`` paces production on a thread from ``start()``, one block when its
last frame is due, like a live sound card (a consumer that falls behind overruns, counted).
``realtime=False`` produces on demand inside :meth:`read`, as fast as the consumer reads,
losing nothing; timestamps then run ahead of the wall clock (still ``host_time0 + k / rate``).
"""
from __future__ import annotations

import logging
import threading
import time
from abc import abstractmethod

import numpy as np

from .source import RingSource

log = logging.getLogger(__name__)

LATE_S = 0.05
"""A paced block produced later than this after it was due counts in ``late_blocks``."""


class BlockSource(RingSource):
    def __init__(self, sample_rate: float, channels: int, dtype: np.dtype | str | type, *,
                 blocksize: int, realtime: bool, buffer_seconds: float, name: str,
                 host_time0: float | None) -> None:
        super().__init__(sample_rate, channels, dtype, buffer_seconds, name)
        if blocksize < 1:
            raise ValueError("blocksize must be at least 1 frame")
        if blocksize > self.buffer_seconds * self.sample_rate:
            raise ValueError("blocksize is longer than the ring buffer (buffer_seconds)")
        self.blocksize = int(blocksize)
        self.realtime = bool(realtime)
        self.host_time0_setting = host_time0
        self.host_time0 = 0.0
        self._pace0 = 0.0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._st.timestamp_source = "ideal"

    @abstractmethod
    def _open(self) -> None:
        """Prepare to produce from frame 0 (open the file, reset the generator)."""

    @abstractmethod
    def _next_block(self, first_index: int, n: int) -> np.ndarray | None:
        """Up to ``n`` frames starting at ``first_index``, as ``(frames, channels)`` in the
        ring's dtype (may be a view of a reused buffer); None or empty at the end."""

    def _close(self) -> None:
        """Release what :meth:`_open` took."""

    def start(self) -> BlockSource:
        if self._running:
            return self
        self._open()
        self._make_ring()
        self._st.timestamp_source = "ideal"
        self._pace0 = time.monotonic()
        self.host_time0 = (self._pace0 if self.host_time0_setting is None
                           else float(self.host_time0_setting))
        self._stop.clear()
        self._running = True
        self._pull_mode = not self.realtime
        if self.realtime:
            self._thread = threading.Thread(target=self._run, daemon=True,
                                            name=f"audio-{self.name}")
            self._thread.start()
        return self

    def stop(self) -> None:
        if not self._running and self._thread is None:
            return
        self._stop.set()
        thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join()
        self._thread = None
        self._close()
        self._set_finished()

    def time_of(self, index: int) -> float:
        return self.host_time0 + index / self.sample_rate

    def _produce_next(self) -> bool:
        ring = self._ring
        assert ring is not None
        k = ring.write_index
        block = self._next_block(k, self.blocksize)
        if block is None or block.shape[0] == 0:
            return False
        self._produce(block, self.host_time0 + k / self.sample_rate, self.sample_rate)
        return True

    def _pull(self) -> bool:
        return self._produce_next()

    def _run(self) -> None:
        ring = self._ring
        assert ring is not None
        fs = self.sample_rate
        try:
            while not self._stop.is_set():
                due = self._pace0 + (ring.write_index + self.blocksize) / fs
                wait = due - time.monotonic()
                if wait > 0 and self._stop.wait(wait):
                    break
                if time.monotonic() - due > LATE_S:
                    self._st.late_blocks += 1
                if not self._produce_next():
                    break
        except Exception:
            self._st.callback_errors += 1
            log.exception("%s: producer failed", self.name)
        finally:
            self._set_finished()
