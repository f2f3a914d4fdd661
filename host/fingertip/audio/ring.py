"""A preallocated ring buffer of audio frames with absolute frame indices.

One producer (the audio callback thread) and one consumer. The producer never blocks and
never allocates: it copies each block into at most two slices of the preallocated array and
records the block's first index and host time in preallocated record arrays. The consumer
reads sequentially (:meth:`RingBuffer.read`) or by absolute index range
(:meth:`RingBuffer.read_range`).

Lock-free by a claim/publish protocol: the producer announces how far it is about to write
(``_claim``) before copying and publishes ``_write`` after. A consumer copies, then looks at
``_claim`` again: frames that the producer may have overwritten during the copy are dropped
and counted as overrun, never returned. So a slow consumer loses the oldest frames, knows
how many (``Chunk.lost_before``, ``overruns_frames``), and never sees torn data.
"""
from __future__ import annotations

import numpy as np

from .chunk import Chunk

SUPPORTED_DTYPES = (np.dtype(np.int16), np.dtype(np.int32), np.dtype(np.float32))


class RingBuffer:
    """``capacity`` frames of ``channels`` channels, dtype int16, int32 or float32.

    ``start_index`` is the absolute index of the first frame written (0 for a new stream).
    ``max_blocks`` bounds the block records used for timestamps; frames whose block record
    has been recycled get their time extrapolated from the oldest record still held.
    """

    def __init__(self, capacity: int, channels: int, dtype: np.dtype | str | type,
                 sample_rate: float, *, start_index: int = 0,
                 max_blocks: int | None = None) -> None:
        dt = np.dtype(dtype)
        if dt not in SUPPORTED_DTYPES:
            raise ValueError(f"unsupported sample dtype {dt}: use int16, int32 or float32")
        if capacity < 1:
            raise ValueError("capacity must be at least one frame")
        if channels < 1:
            raise ValueError("channels must be at least 1")
        if not sample_rate > 0:
            raise ValueError("sample_rate must be positive")
        if start_index < 0:
            raise ValueError("start_index must not be negative")
        self.capacity = int(capacity)
        self.channels = int(channels)
        self.dtype = dt
        self.sample_rate = float(sample_rate)
        self.start_index = int(start_index)
        self._buf = np.zeros((self.capacity, self.channels), dtype=dt)
        nrec = max_blocks if max_blocks is not None else max(64, self.capacity // 32)
        if nrec < 1:
            raise ValueError("max_blocks must be at least 1")
        self._rec_index = np.zeros(nrec, dtype=np.int64)
        self._rec_time = np.zeros(nrec, dtype=np.float64)
        self._rec_rate = np.zeros(nrec, dtype=np.float64)
        self._nrec = nrec
        self._rec_count = 0
        self._write = self.start_index
        self._claim = self.start_index
        self._read = self.start_index
        self.blocks = 0
        self.overruns_frames = 0
        """Frames lost to overwriting, as found by the consumer so far (see ``lost_pending``)."""
        self.overruns = 0
        self.frames_read = 0

    # --- producer -------------------------------------------------------------------------

    @property
    def write_index(self) -> int:
        """Absolute index of the next frame to be written (= frames written + start_index)."""
        return self._write

    def write(self, block: np.ndarray, host_time: float, host_rate: float | None = None, *,
              casting: str = "same_kind") -> int:
        """Append ``block`` (``(frames, channels)``, or ``(frames,)`` for one channel).

        ``host_time`` is the monotonic time of the block's first frame, ``host_rate`` the
        frames per host second (default: the nominal rate). Returns the first frame's index.
        A block longer than the whole buffer keeps only its last ``capacity`` frames.
        """
        n = block.shape[0]
        if block.ndim == 1:
            if self.channels != 1:
                raise ValueError(f"1-D block for a {self.channels}-channel ring buffer")
            block = block.reshape(n, 1)
        elif block.ndim != 2 or block.shape[1] != self.channels:
            raise ValueError(f"block of shape {block.shape} for a {self.channels}-channel "
                             "ring buffer")
        w = self._write
        if n == 0:
            return w
        cap = self.capacity
        rate = self.sample_rate if host_rate is None else host_rate
        skip = n - cap if n > cap else 0  # only the last `cap` frames can be kept
        self._claim = w + n
        pos = (w + skip) % cap
        m = n - skip
        first = min(m, cap - pos)
        np.copyto(self._buf[pos:pos + first], block[skip:skip + first], casting=casting)
        if first < m:
            np.copyto(self._buf[:m - first], block[skip + first:], casting=casting)
        r = self._rec_count % self._nrec
        self._rec_index[r] = w
        self._rec_time[r] = host_time
        self._rec_rate[r] = rate
        self._rec_count += 1
        self.blocks += 1
        self._write = w + n
        return w

    # --- consumer -------------------------------------------------------------------------

    @property
    def read_index(self) -> int:
        """Absolute index of the next frame :meth:`read` returns."""
        return self._read

    @property
    def available(self) -> int:
        """Frames written and not yet read (including any that were already overwritten)."""
        return self._write - self._read

    @property
    def oldest_index(self) -> int:
        """Oldest absolute index still held in the buffer."""
        return max(self.start_index, self._write - self.capacity)

    @property
    def lost_pending(self) -> int:
        """Frames already overwritten that the consumer has not yet stepped over."""
        return max(0, self._claim - self.capacity - self._read)

    def read(self, max_frames: int | None = None, out: np.ndarray | None = None
             ) -> Chunk | None:
        """The next unread frames (at most ``max_frames``), or None when there are none.

        ``out`` (``(n, channels)``, the ring's dtype) receives the samples instead of a new
        array; the chunk's samples are then a view of it.
        """
        lost = 0
        while True:
            w = self._write
            r = self._read
            gone = self._claim - self.capacity - r
            if gone > 0:  # overwritten before we got to them
                lost += gone
                r += gone
                self._read = r
            n = w - r
            if max_frames is not None:
                n = min(n, max_frames)
            if out is not None:
                n = min(n, out.shape[0])
            if n <= 0:
                if lost:
                    self._count_lost(lost)
                return None
            dst = self._copy_out(r, n, out)
            # Frames the producer may have started overwriting while we copied.
            torn = self._claim - self.capacity - r
            if torn > 0:
                lost += min(torn, n)
                self._read = r + min(torn, n)
                if torn >= n:
                    continue
                dst = dst[torn:]
                r += torn
                n -= torn
            self._read = r + n
            if lost:
                self._count_lost(lost)
            self.frames_read += n
            t, rate = self._time_of(r)
            return Chunk(dst, r, self.sample_rate, t, rate, lost)

    def read_range(self, start: int, stop: int, out: np.ndarray | None = None) -> Chunk:
        """Frames ``start`` to ``stop - 1`` by absolute index, without moving the read cursor.

        Raises IndexError when part of the range has not been written yet, or has already
        been overwritten (the message says which frames are available).
        """
        if stop < start:
            raise ValueError("stop must not be before start")
        n = stop - start
        if n > self.capacity:
            raise IndexError(f"range of {n} frames is longer than the buffer "
                             f"({self.capacity} frames)")
        if stop > self._write:
            raise IndexError(f"frames {start}..{stop - 1} not captured yet "
                             f"(available: {self.oldest_index}..{self._write - 1})")
        if start < self._claim - self.capacity or start < self.start_index:
            raise IndexError(f"frames from {start} already overwritten "
                             f"(available: {self.oldest_index}..{self._write - 1})")
        dst = self._copy_out(start, n, out)
        if start < self._claim - self.capacity:
            raise IndexError(f"frames from {start} were overwritten while being read")
        t, rate = self._time_of(start)
        return Chunk(dst, start, self.sample_rate, t, rate, 0)

    def time_of(self, index: int) -> float:
        """Host time of absolute frame ``index`` from the block records (any index)."""
        return self._time_of(index)[0]

    def reset_counters(self) -> None:
        self.overruns_frames = 0
        self.overruns = 0

    # --- internals ------------------------------------------------------------------------

    def _count_lost(self, lost: int) -> None:
        self.overruns_frames += lost
        self.overruns += 1

    def _copy_out(self, start: int, n: int, out: np.ndarray | None) -> np.ndarray:
        if out is None:
            dst = np.empty((n, self.channels), dtype=self.dtype)
        else:
            if out.dtype != self.dtype or out.ndim != 2 or out.shape[1] != self.channels:
                raise ValueError(f"out must be (n, {self.channels}) {self.dtype}")
            dst = out[:n]
        pos = start % self.capacity
        first = min(n, self.capacity - pos)
        dst[:first] = self._buf[pos:pos + first]
        if first < n:
            dst[first:] = self._buf[:n - first]
        return dst

    def _time_of(self, index: int) -> tuple[float, float]:
        count = self._rec_count
        if count == 0:
            return float("nan"), self.sample_rate
        nrec = self._nrec
        newest = (count - 1) % nrec
        held = min(count, nrec)
        oldest = (newest - held + 1) % nrec
        idx = self._rec_index
        # Records are in increasing index order from `oldest` around to `newest`.
        if oldest <= newest:
            j = oldest + int(np.searchsorted(idx[oldest:newest + 1], index, "right")) - 1
            j = max(j, oldest)
        else:
            k = int(np.searchsorted(idx[oldest:], index, "right"))
            if k == nrec - oldest:  # past the end of the first segment: look in the second
                k2 = int(np.searchsorted(idx[:newest + 1], index, "right"))
                j = max(k2 - 1, 0) if k2 else nrec - 1
            else:
                j = oldest + max(k - 1, 0)
        rate = float(self._rec_rate[j])
        return float(self._rec_time[j]) + (index - int(idx[j])) / rate, rate
