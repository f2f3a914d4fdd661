"""The :class:`AudioSource` interface, its errors, and the ring-buffered base of all sources."""
from __future__ import annotations

import math
import threading
import time
from abc import ABC, abstractmethod
from collections.abc import Iterator
from dataclasses import replace

import numpy as np

from ..errors import DeviceError

from .chunk import AudioStats, Chunk
from .ring import SUPPORTED_DTYPES, RingBuffer


class AudioError(DeviceError):
    """Base class of the errors of the audio layer (a :class:`~fingertip.errors.DeviceError`,
    a RuntimeError; exit status 2: the sound card or file the user named)."""

    exit_code = 2


class AudioBackendError(AudioError):
    """PortAudio (or sounddevice) is missing or failed."""


class AudioDeviceNotFound(AudioError, LookupError):
    """No input device (or sound card) matches; the message lists what exists."""


class AudioSettingsError(AudioError, ValueError):
    """The device refuses the rate, channel count or sample format asked for."""


class AudioFileError(AudioError, OSError):
    """A recording is missing, unreadable or not WAV/FLAC."""


def check_dtype(dtype: np.dtype | str | type) -> np.dtype:
    dt = np.dtype(dtype)
    if dt not in SUPPORTED_DTYPES:
        raise AudioSettingsError(f"unsupported sample format {dt}: use int16, int32 "
                                 "(24-bit cards deliver int32 with the low byte zero) "
                                 "or float32")
    return dt


class AudioSource(ABC):
    """A stream of audio frames: a sound card, a file or a simulator.

    ``start()`` begins producing into a ring buffer; ``read()`` returns the next
    :class:`Chunk` (sample-exact indices and host timestamps); ``stop()`` ends it. Sources
    are context managers and iterable through :meth:`chunks`.
    """

    sample_rate: float
    channels: int
    dtype: np.dtype
    name: str

    @abstractmethod
    def start(self) -> AudioSource:
        """Begin producing. Returns ``self``."""

    @abstractmethod
    def stop(self) -> None:
        """Stop producing (frames already captured can still be read)."""

    @abstractmethod
    def read(self, max_frames: int | None = None, timeout: float | None = None,
             out: np.ndarray | None = None) -> Chunk | None:
        """The next unread frames (at most ``max_frames``).

        Waits up to ``timeout`` seconds (``None``: until data comes or the source ends; 0:
        never). Returns None on timeout or when the source has ended and everything was read.
        """

    @abstractmethod
    def read_range(self, start: int, stop: int) -> Chunk:
        """Frames ``start`` to ``stop - 1`` by absolute index, still in the ring buffer."""

    @abstractmethod
    def time_of(self, index: int) -> float:
        """Best current estimate of the host monotonic time of absolute frame ``index``."""

    @property
    @abstractmethod
    def stats(self) -> AudioStats:
        """A snapshot of the counters."""

    @property
    @abstractmethod
    def running(self) -> bool:
        """Started, not stopped, and not ended by itself."""

    @property
    @abstractmethod
    def finished(self) -> bool:
        """The producer has ended (end of file, duration reached, stream gone, stopped)."""

    def chunks(self, max_frames: int | None = None, timeout: float | None = None
               ) -> Iterator[Chunk]:
        """Chunks until the source ends (or until a read times out, with ``timeout``)."""
        while True:
            chunk = self.read(max_frames, timeout)
            if chunk is None:
                return
            yield chunk

    def __enter__(self) -> AudioSource:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


class RingSource(AudioSource):
    """Shared machinery: a ring buffer filled by a producer, a consumer cursor, counters.

    Subclasses create the ring in ``start()`` with :meth:`_make_ring`, write blocks with
    :meth:`_produce` from their producer thread (or from :meth:`_pull` when they produce on
    demand), and call :meth:`_set_finished` when the producer ends.
    """

    def __init__(self, sample_rate: float, channels: int, dtype: np.dtype | str | type,
                 buffer_seconds: float, name: str) -> None:
        if not sample_rate > 0:
            raise AudioSettingsError(f"sample rate must be positive, not {sample_rate}")
        if not 1 <= channels <= 64:
            raise AudioSettingsError(f"channel count must be 1..64, not {channels}")
        if not buffer_seconds > 0:
            raise ValueError("buffer_seconds must be positive")
        self.sample_rate = float(sample_rate)
        self.channels = int(channels)
        self.dtype = check_dtype(dtype)
        self.buffer_seconds = float(buffer_seconds)
        self.name = name
        self._ring: RingBuffer | None = None
        self._st = AudioStats()
        self._data = threading.Event()
        self._running = False
        self._finished = False
        self._pull_mode = False

    # --- subclass helpers -----------------------------------------------------------------

    def _make_ring(self) -> RingBuffer:
        capacity = max(1, math.ceil(self.buffer_seconds * self.sample_rate))
        self._ring = RingBuffer(capacity, self.channels, self.dtype, self.sample_rate)
        self._st = AudioStats(timestamp_source=self._st.timestamp_source)
        self._finished = False
        self._data.clear()
        return self._ring

    def _produce(self, block: np.ndarray, host_time: float, host_rate: float,
                 casting: str = "same_kind") -> None:
        ring = self._ring
        assert ring is not None
        ring.write(block, host_time, host_rate, casting=casting)
        self._st.frames += block.shape[0]
        self._st.blocks += 1
        self._data.set()

    def _set_finished(self) -> None:
        self._finished = True
        self._running = False
        self._data.set()

    def _pull(self) -> bool:
        """Produce one block on demand (pull-mode sources). False at the end."""
        return False

    # --- AudioSource ------------------------------------------------------------------------

    def _require_ring(self) -> RingBuffer:
        if self._ring is None:
            raise RuntimeError(f"audio source {self.name!r} was never started")
        return self._ring

    def read(self, max_frames: int | None = None, timeout: float | None = None,
             out: np.ndarray | None = None) -> Chunk | None:
        ring = self._require_ring()
        if max_frames is not None and max_frames < 1:
            raise ValueError("max_frames must be at least 1")
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            chunk = ring.read(max_frames, out)
            if chunk is not None:
                return chunk
            if self._pull_mode and not self._finished:
                if not self._pull():
                    self._set_finished()
                continue
            if self._finished or not self._running:
                return None
            self._data.clear()
            if ring.available > 0 or self._finished:
                continue
            if deadline is None:
                self._data.wait()
            else:
                remaining = deadline - time.monotonic()
                if remaining <= 0 or not self._data.wait(remaining):
                    return ring.read(max_frames, out)

    def read_range(self, start: int, stop: int) -> Chunk:
        return self._require_ring().read_range(start, stop)

    def time_of(self, index: int) -> float:
        return self._require_ring().time_of(index)

    @property
    def stats(self) -> AudioStats:
        ring = self._ring
        if ring is None:
            return replace(self._st)
        return replace(self._st, frames_read=ring.frames_read,
                       overruns_frames=ring.overruns_frames + ring.lost_pending,
                       overruns=ring.overruns + (1 if ring.lost_pending else 0))

    @property
    def running(self) -> bool:
        return self._running and not self._finished

    @property
    def finished(self) -> bool:
        return self._finished

    @property
    def next_index(self) -> int:
        """Absolute index of the next frame the producer will write."""
        return self._require_ring().write_index

    @property
    def ring(self) -> RingBuffer:
        return self._require_ring()
