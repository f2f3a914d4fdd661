"""Host monotonic time <-> the Unix-epoch nanoseconds stored in recordings.

Header stamps and MCAP log times are ``time.monotonic()`` of the recording host, shifted
onto the Unix epoch by one offset measured when the recording starts (and stored in the
file's ``fingertip`` metadata record as ``monotonic_to_unix_ns``). So stamps read as wall
clock time in every tool, never jump when NTP steps the wall clock during a recording, and
``stamp - monotonic_to_unix_ns`` gives back the monotonic time the live code saw.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

NS = 1_000_000_000


@dataclass(frozen=True, slots=True)
class TimeBase:
    offset_ns: int
    """Unix-epoch nanoseconds minus monotonic nanoseconds."""

    @classmethod
    def measure(cls, tries: int = 7) -> TimeBase:
        """The offset now: the tightest of a few monotonic/wall/monotonic sandwiches."""
        best: tuple[int, int] | None = None
        for _ in range(tries):
            m0 = time.monotonic_ns()
            w = time.time_ns()
            m1 = time.monotonic_ns()
            if best is None or m1 - m0 < best[0]:
                best = (m1 - m0, w - (m0 + m1) // 2)
        assert best is not None
        return cls(best[1])

    def to_ns(self, monotonic_s: float) -> int:
        """``time.monotonic()`` seconds -> Unix-epoch nanoseconds (rounded to 1 ns)."""
        if not math.isfinite(monotonic_s):
            raise ValueError(f"time {monotonic_s} is not finite")
        return round(monotonic_s * NS) + self.offset_ns

    def to_monotonic(self, ns: int) -> float:
        """Unix-epoch nanoseconds -> ``time.monotonic()`` seconds of the recording host."""
        return (ns - self.offset_ns) / NS

    @staticmethod
    def to_unix(ns: int) -> float:
        return ns / NS
