"""What every source of frames offers user code: a live device, a replayed recording."""
from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .fingertip import Frame


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
