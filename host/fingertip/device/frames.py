"""A frame as user code sees it, and what every source of frames offers: a live device, a
replayed recording."""
from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class Frame:
    """One sample frame, as user code sees it."""

    seq: int
    device_time_us: int
    """Device microseconds, unwrapped (no 32-bit wraparound)."""
    host_time: float
    """Device time mapped to this host's ``time.monotonic()`` seconds (drift corrected): when
    the chips signalled this reading ready, as this host's clock would have read then."""
    arrival_time: float
    """``time.monotonic()`` when the frame's last byte was read."""
    counts: tuple[int, ...]
    """Raw HX711 counts per channel, tare offsets already subtracted by the device."""
    timeout_mask: int = 0
    saturation_mask: int = 0

    @property
    def ok(self) -> bool:
        """No channel timed out or saturated."""
        return not (self.timeout_mask | self.saturation_mask)

    def valid(self, channel: int) -> bool:
        return not ((self.timeout_mask | self.saturation_mask) >> channel & 1)


class FrameSource(ABC):
    """Iteration and callbacks over ``read()``; subclasses set ``self._callbacks = []`` and
    implement ``read(timeout) -> Frame | None``."""

    _callbacks: list[Callable[[Frame], None]]

    @abstractmethod
    def read(self, timeout: float | None = None) -> Frame | None:
        """The next frame, or None after ``timeout`` seconds (or at the end)."""

    def frames(self, timeout: float | None = None) -> Iterator[Frame]:
        """Iterate over frames until ``timeout`` passes without one, or the source ends."""
        while (f := self.read(timeout)) is not None:
            yield f

    def __iter__(self) -> Iterator[Frame]:
        return self.frames()

    def add_callback(self, fn: Callable[[Frame], None]) -> None:
        """Call ``fn(frame)`` for every frame, from the source's own thread (keep it short)."""
        self._callbacks.append(fn)

    def remove_callback(self, fn: Callable[[Frame], None]) -> None:
        self._callbacks.remove(fn)
