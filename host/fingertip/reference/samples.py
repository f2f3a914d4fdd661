"""Reference samples and the interface of a live reference input."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from ..errors import NetworkError


class ReferenceError(NetworkError, ValueError):
    """The reference cannot be used (no packets, never moves, wrong file, an address that
    does not resolve...): one line; a :class:`~fingertip.errors.NetworkError` and a
    ValueError; exit status 2 (the reference the user gave)."""

    exit_code = 2


@dataclass
class ReferenceSamples:
    """Forces from the reference sensor at times of one clock (seconds).

    ``force``: (N, 3) Fx, Fy, Fz in newtons, in the fingertip's frame (the force applied to
    the fingertip, docs/calibration.md). ``torque``: (N, 3) N m, or None.
    """

    times_s: np.ndarray
    force: np.ndarray
    torque: np.ndarray | None = None
    source: str = ""
    counters: dict[str, int] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.times_s)

    def require_usable(self, min_range_n: float = 0.2) -> None:
        """Raise :class:`ReferenceError` when there is nothing to calibrate against."""
        if len(self) < 10:
            raise ReferenceError(f"{self.source or 'the reference'}: only {len(self)} "
                                 "samples arrived" + (unusable_text(self.counters)
                                 or " (is it streaming to this host?)"))
        mag = np.hypot(self.force[:, 0], self.force[:, 1])
        span = float(np.percentile(mag, 99) - np.percentile(mag, 1))
        if span < min_range_n:
            raise ReferenceError(
                f"{self.source or 'the reference'} never moves: its planar force spans "
                f"{span:.3f} N (need >= {min_range_n} N); press the fingertip while recording, "
                "and check that the reference is the sensor under the fingertip")

    def rotated(self, matrix: np.ndarray) -> ReferenceSamples:
        """The same samples in another frame (a 3x3 rotation: sensor -> fingertip)."""
        m = np.asarray(matrix, float)
        return ReferenceSamples(self.times_s, self.force @ m.T,
                                None if self.torque is None else self.torque @ m.T,
                                self.source, dict(self.counters))


class WrenchSource(Protocol):
    """A live reference: RDT here, a ROS 2 WrenchStamped topic (issue 16) elsewhere. Times
    must be this host's ``time.monotonic()`` seconds, the clock of ``Frame.host_time``."""

    name: str

    def start(self) -> None: ...

    def stop(self) -> ReferenceSamples: ...


def unusable_text(counters: dict[str, int]) -> str:
    """``"; 2000 packets arrived but ..."`` saying why packets that arrived were not used
    (wrong size, the sensor's status bit set), or "" when none were refused."""
    bad, status = counters.get("bad_size", 0), counters.get("status_errors", 0)
    if not bad and not status:
        return ""
    parts = []
    if bad:
        parts.append(f"{bad} of the wrong size (not RDT records: is it an RDT sensor?)")
    if status:
        parts.append(f"{status} with the sensor's status bit set (the sensor reports an "
                     "error: see its web page)")
    total = counters.get("packets", 0) + bad
    return f"; {total} packets arrived but were not used: " + ", ".join(parts)
