"""What every audio source hands out: a :class:`Chunk` of frames, and its counters."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, slots=True, eq=False)
class Chunk:
    """Consecutive frames of one source, with their absolute indices and host time.

    ``samples`` has shape ``(frames, channels)`` (the layout of sounddevice and soundfile) and
    the dtype as captured: int16, int32 (24-bit cards: the low byte is zero) or float32.
    Frame ``first_index + i`` is ``samples[i]``; indices count from the source's start and
    never wrap. ``host_time`` is the ``time.monotonic()`` second at which ``samples[0]`` was
    digitised, ``host_rate`` the frames per host second at that moment (the nominal
    ``sample_rate`` corrected for the sound card's clock drift when it is measured; up to
    0.5 % above that while a live source's stamps catch up with a clock fit that moved back,
    so that ``host_time`` never goes back from one chunk to the next).
    """

    samples: np.ndarray
    first_index: int
    sample_rate: float
    host_time: float
    host_rate: float
    lost_before: int = 0
    """Frames overwritten before they were read, just before this chunk (counted, too)."""

    @property
    def frames(self) -> int:
        return int(self.samples.shape[0])

    @property
    def channels(self) -> int:
        return int(self.samples.shape[1])

    @property
    def end_index(self) -> int:
        """One past the last frame's index."""
        return self.first_index + self.frames

    @property
    def duration(self) -> float:
        return self.frames / self.sample_rate

    def time_of(self, index: int) -> float:
        """Host monotonic time of absolute frame ``index`` (may lie outside the chunk)."""
        return self.host_time + (index - self.first_index) / self.host_rate

    def times(self) -> np.ndarray:
        """Host monotonic time of every frame (float64, one per frame)."""
        return self.host_time + np.arange(self.frames, dtype=np.float64) / self.host_rate


@dataclass(slots=True)
class AudioStats:
    """Counters of one audio source. Every kind of loss has its own counter.

    A snapshot: sources return a copy from :attr:`AudioSource.stats`.
    """

    frames: int = 0
    """Frames written into the ring buffer (captured, read from file or generated)."""
    blocks: int = 0
    """Blocks written (audio callbacks for a live source)."""
    frames_read: int = 0
    """Frames handed to the consumer."""
    overruns_frames: int = 0
    """Frames overwritten in the ring buffer before the consumer read them."""
    overruns: int = 0
    """Times the consumer found that it had lost frames to the ring buffer."""
    input_overflows: int = 0
    """Callbacks flagged ``input_overflow`` by PortAudio: the driver or server dropped input."""
    input_underflows: int = 0
    """Callbacks flagged ``input_underflow`` by PortAudio."""
    xruns: int = 0
    """Callbacks with any overflow or underflow flag."""
    callback_errors: int = 0
    """Exceptions caught inside the audio callback (logged; the stream keeps running)."""
    adc_time_rejected: int = 0
    """Callbacks whose ADC timestamp was 0, implausible or inconsistent with the frame count."""
    clock_steps: int = 0
    """Jumps of the frame-count clock (frames lost upstream without a flag, suspend, ...)."""
    late_blocks: int = 0
    """Paced file/simulated sources: blocks produced more than 50 ms after they were due."""
    stream_errors: int = 0
    """The stream ended by itself (device unplugged, server gone)."""
    timestamp_source: str = ""
    """"adc" (PortAudio's ADC time), "frames" (frame counts fitted to callback arrivals),
    "ideal" (files and simulators: host_time0 + index / rate)."""
