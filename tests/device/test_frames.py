"""A frame says which channels are valid; a frame source iterates until it has no more."""
from __future__ import annotations

from fingertip.device import Frame
from fingertip.device.frames import FrameSource


def test_masks_say_which_channels_are_valid():
    f = Frame(1, 0, 0.0, 0.0, (1, 2, 3, 4), timeout_mask=0b0001, saturation_mask=0b0100)
    assert not f.ok
    assert [f.valid(c) for c in range(4)] == [False, True, False, True]
    assert Frame(2, 0, 0.0, 0.0, (1, 2)).ok


class ListSource(FrameSource):
    def __init__(self, frames: list[Frame]) -> None:
        self._callbacks = []
        self._frames = list(frames)

    def read(self, timeout: float | None = None) -> Frame | None:
        return self._frames.pop(0) if self._frames else None


def test_a_source_iterates_until_read_returns_none():
    frames = [Frame(k, k, 0.0, 0.0, (k,)) for k in range(3)]
    assert list(ListSource(frames)) == frames
    assert list(ListSource([]).frames(timeout=0.0)) == []
