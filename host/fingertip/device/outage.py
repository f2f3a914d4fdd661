"""Frames lost across an outage, and device restarts nobody announced. Pure: no I/O, no clock
of its own (the caller passes host times).

Inside one connection the decoder counts the frames missing by sequence number. When the
link is lost and comes back, or the device resets, that count starts again, so the frames
between the last frame before the break and the first one after would go uncounted. This
module measures that gap at the first frame after it:

- the device kept running (a link hiccup, a cable re-plugged on a powered board): its
  microseconds advanced with the host clock across the gap, so the frames missing are the
  device time between the two frames over the nominal frame period, less one, and never
  more than the sequence numbers skipped (each frame takes one; other messages take some);
- the device restarted (its boot ``INFO`` arrived, or its microseconds and sequence numbers
  do not continue the old ones, as after a reset whose boot message was lost with the link):
  its clock began again, so the gap is measured on the host clock, over the nominal period.

Sequence numbers wrap at 2^16 and device microseconds at 2^32 (71.6 minutes): gaps are taken
modulo those, so a wrap inside an outage is not mistaken for a restart.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

SEQ_MODULUS = 1 << 16
TIME_MODULUS = 1 << 32

CONTINUITY_S = 0.1
"""Device and host clocks must agree on a gap's length within this (plus
:data:`CONTINUITY_PPM`) for the device to count as having run on through it: the host's side
of a frame's time is known to a few milliseconds, a restarted device's clock is off by at
least the time the old one had run."""
CONTINUITY_PPM = 5000
"""... and within this share of the gap (the Uno's resonator: a few hundred ppm; generous)."""
LATE_STAMPS_S = 2.0
"""How much longer than the host's stamps say a gap may be on the clock of a device that ran
on. Stamps are late by as much as the host was busy when the frames came: a young clock map
(a stream whose first frames were held up) only lowers its line when on-time frames arrive,
so the last stamp before a break can be late by that much, the first after it not. Late stamps
only ever shorten the host's view of a gap; a restart always lengthens it (its clock began
again), unless its device time went back, which makes the device's gap, modulo 2^32 us,
over 70 minutes."""
SEQ_SLACK = 16
"""Messages other than frames a device may send in a gap (a STATS a second, late ACKs)."""
MIN_MEASURE_S = 2.0
"""Device seconds of unbroken frames from which their own period replaces the nominal one
(an HX711's rate is its oscillator's: a few percent off 10 or 80 SPS)."""


class FramePoint(Protocol):
    """What the tracker reads of a frame (:class:`fingertip.device.Frame` has it)."""

    seq: int
    device_time_us: int
    host_time: float
    arrival_time: float


@dataclass(frozen=True, slots=True)
class Outage:
    """One break in a device's frames, measured at the first frame after it."""

    gone_s: float
    """Host seconds from the last frame before the break to the first after it."""
    frames_lost: int
    """Sample frames missing between the two."""
    restarted: bool
    """The device restarted during the break (counted in ``device_resets``)."""
    reset_announced: bool
    """Its boot ``INFO`` arrived (otherwise the restart was inferred from its clock)."""


def seq_gap(before: int, after: int) -> int:
    """Sequence numbers skipped between two messages (16-bit, wrapping)."""
    return (after - before - 1) % SEQ_MODULUS


def device_gap_us(before: int, after: int) -> int:
    """Device microseconds from one frame to a later one (32-bit, wrapping)."""
    return (after - before) % TIME_MODULUS


def periods(seconds: float, period_s: float) -> int:
    """Whole frame periods in ``seconds`` (to the nearest; never negative)."""
    return max(0, round(seconds / period_s))


def continued(before: FramePoint, after: FramePoint, period_s: float) -> bool:
    """True when ``after`` comes from the device that sent ``before`` without a restart in
    between: device time advanced as much as host time did (or up to
    :data:`LATE_STAMPS_S` more, as the host's stamps can be late), and the sequence numbers about
    one per frame period (each frame takes one; a few other messages may take more; a
    restarted device numbers from 0 again), unless so many passed that they wrapped. The
    very next frame (number and device time one step on) continues whatever the host's
    stamps say: it was held up on the way across the break, and nothing was lost."""
    host_s = host_seconds(after) - host_seconds(before)
    dev_s = device_gap_us(before.device_time_us, after.device_time_us) * 1e-6
    if seq_gap(before.seq, after.seq) == 0 and abs(dev_s - period_s) <= 0.5 * period_s:
        return True
    tol = CONTINUITY_S + abs(host_s) * CONTINUITY_PPM * 1e-6
    if host_s - dev_s > tol or dev_s - host_s > tol + LATE_STAMPS_S:
        return False
    n = periods(dev_s, period_s)
    if 2 * n + SEQ_SLACK >= SEQ_MODULUS:
        return True
    advance = seq_gap(before.seq, after.seq) + 1
    return 0.9 * n - 1 <= advance <= 2 * n + SEQ_SLACK


def host_seconds(f: FramePoint) -> float:
    """The frame's clock-mapped host time, or its arrival when the map had none."""
    t = f.host_time
    return t if math.isfinite(t) else f.arrival_time


def frames_missing(before: FramePoint, after: FramePoint, period_s: float,
                   restarted: bool) -> int:
    """Sample frames that should have come between ``before`` and ``after`` at one frame
    per ``period_s``: by device time and sequence numbers if the device ran on, by the host
    clock if it restarted."""
    if restarted:
        return max(0, periods(host_seconds(after) - host_seconds(before), period_s) - 1)
    n = periods(device_gap_us(before.device_time_us, after.device_time_us) * 1e-6,
                period_s) - 1
    if n + 1 < SEQ_MODULUS:  # each frame took a sequence number: no more can be missing
        n = min(n, seq_gap(before.seq, after.seq))
    return max(0, n)


class OutageTracker:
    """Follows one device's frames across breaks; the counters only ever grow.

    Call :meth:`frame` for every frame handed out, :meth:`link_lost` when the link goes,
    :meth:`reset_seen` at a boot ``INFO``. The first frame after a break is compared with
    the last one before it, at the period the frames before it kept (measured over at least
    :data:`MIN_MEASURE_S`; the nominal period until then or when it is far off).
    """

    __slots__ = ("outage_frames", "device_resets", "outages", "last", "_last", "_broken",
                 "_period_s", "_announced", "_lost_at", "_first", "_count", "_measured")

    WINDOW = 4096
    """Frames over which the period is measured (about 51 s at 80 Hz)."""

    def __init__(self) -> None:
        self.outage_frames = 0
        """Sample frames missing across breaks."""
        self.device_resets = 0
        """Restarts: announced by a boot ``INFO``, or inferred at the first frame after."""
        self.outages = 0
        """Breaks measured (a frame before and one after)."""
        self.last: Outage | None = None
        self._last: FramePoint | None = None
        self._broken = True  # the first frame starts the first stretch
        self._period_s = 0.0
        self._announced = False
        self._lost_at: float | None = None
        self._first: FramePoint | None = None
        self._count = 0
        self._measured: float | None = None

    def frame(self, f: FramePoint) -> Outage | None:
        """One frame handed out; returns the outage it ends, if it ends one."""
        if not self._broken:
            self._last = f
            self._count += 1
            if self._count >= self.WINDOW:
                self._measured = self._window_period() or self._measured
                self._first, self._count = f, 1
            return None
        before, self._last = self._last, f
        self._first, self._count = f, 1
        announced, self._announced, self._broken = self._announced, False, False
        self._lost_at = None
        if before is None:  # nothing before the break to measure from
            return None
        restarted = announced or not continued(before, f, self._period_s)
        lost = frames_missing(before, f, self._period_s, restarted)
        if restarted and not announced:
            self.device_resets += 1
        self.outage_frames += lost
        self.outages += 1
        self.last = Outage(host_seconds(f) - host_seconds(before), lost, restarted, announced)
        return self.last

    def link_lost(self, period_s: float, host_s: float) -> None:
        """The link went at host time ``host_s``; ``period_s``: the nominal frame period."""
        self._break(period_s)
        if self._lost_at is None:
            self._lost_at = host_s

    def reset_seen(self, period_s: float) -> None:
        """A boot ``INFO``: the device restarted (counted now, measured at the next frame)."""
        self._break(period_s)
        self._announced = True
        self.device_resets += 1

    def gone_for(self, now: float) -> float | None:
        """Seconds since the last frame, from the link's loss until a frame comes again
        (None while it is connected)."""
        if self._lost_at is None:
            return None
        since = host_seconds(self._last) if self._last is not None else self._lost_at
        return max(0.0, now - since)

    def _window_period(self) -> float | None:
        """The period of the frames since the stretch began, if they span enough time."""
        first, last, n = self._first, self._last, self._count
        if first is None or last is None or n < 2:
            return None
        span = device_gap_us(first.device_time_us, last.device_time_us) * 1e-6
        return span / (n - 1) if span >= MIN_MEASURE_S else None

    def _break(self, period_s: float) -> None:
        if not (period_s > 0 and math.isfinite(period_s)):
            raise ValueError(f"the frame period must be a positive number of seconds, "
                             f"not {period_s!r}")
        if not self._broken:
            measured = self._window_period() or self._measured
            self._measured = measured
            # A measured period far from the nominal one is not this rate's (the rate was
            # changed since, or frames were lost inside the stretch).
            if measured is not None and abs(measured / period_s - 1) <= 0.2:
                period_s = measured
            self._period_s = period_s
        self._broken = True
