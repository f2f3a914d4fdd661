"""When a finger touches: its calibrated force rising above a threshold over its rest.

A recipe that must find where an object is before acting on it (the shake-and-pick's pusher
finding the end of a box's tray, which may have moved since the box stood square) closes the
finger step by step and feeds :class:`Touch` each frame's force vector. The rest is the mean
vector over frames read with the finger free (subtracted as a vector, as :class:`~.grip.Grip`
zeroes its fingers); a touch is the moving average of the corrected magnitude reaching
``threshold_n``.
"""
from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence


class Touch:
    """One finger's touch detector (see the module text)."""

    def __init__(self, rest: Sequence[tuple[float, float]], threshold_n: float,
                 window: int = 4) -> None:
        if not rest:
            raise ValueError("touch needs at least one rest frame")
        if not threshold_n > 0 or window < 1:
            raise ValueError(f"threshold must be > 0 N and window >= 1, not {threshold_n}, "
                             f"{window}")
        self.rest = (sum(v[0] for v in rest) / len(rest), sum(v[1] for v in rest) / len(rest))
        self.threshold_n = threshold_n
        self._buf: deque[float] = deque(maxlen=window)
        self.touched = False
        self.force_n = 0.0
        """The latest moving average (N)."""

    def feed(self, force: tuple[float, float]) -> bool:
        """One frame's force vector (N); True from the frame the touch is seen on."""
        self._buf.append(math.hypot(force[0] - self.rest[0], force[1] - self.rest[1]))
        self.force_n = sum(self._buf) / len(self._buf)
        # A touch needs a full window: one noisy frame after the start is not one.
        if len(self._buf) == self._buf.maxlen and self.force_n >= self.threshold_n:
            self.touched = True
        return self.touched
