"""Map device microseconds to host monotonic seconds. Pure: the caller supplies both clocks.

A frame's host arrival time is its device time mapped through an unknown offset and rate
(the Uno's resonator runs up to a few hundred ppm off), plus a transport delay that is never
negative and usually near its minimum. So the mapping is fitted to the *lower envelope* of
(device time, arrival time) pairs over a sliding window (:class:`fingertip.clockfit.FrameClock`,
the same fit as the sound card's clock): the earliest arrival of each short bin, under which
the lower convex hull gives the rate. Arrival jitter and late bursts then do not bias the
map; only the minimum delay remains in it (a constant, the same for every frame). This module
adds the 32-bit wraparound of the device's microsecond counter.

Unlike the sound card's fit, this one never takes a stretch of late arrivals for a step of the
clock. A sound card can drop frames upstream without saying so, which shifts its frame count
for good. The device's microsecond counter only restarts with a reset, and that is handled
apart (:meth:`ClockSync.reset`). So frames that keep arriving late mean late transport: a
reader or a simulator that fell behind and stays behind. If the fit took that for a step, it
would map every frame up to that delay late (a second, seen beside a busy host) for as long as
the stretch lasts. Left alone, the old line holds until it leaves the window (``window_s``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..clockfit import FrameClock


class Unwrapper:
    """Extend a wrapping counter (u32 microseconds by default) to an unbounded integer.

    Assumes less than half a wrap passes between two consecutive values (35.8 minutes for
    a u32 microsecond clock). A jump backwards by less than half a wrap is taken as a small
    reordering, not as a wrap.
    """

    def __init__(self, bits: int = 32) -> None:
        self.modulus = 1 << bits
        self._half = self.modulus // 2
        self._last: int | None = None
        self._base = 0
        self.wraps = 0

    def reset(self) -> None:
        self._last = None
        self._base = 0
        self.wraps = 0

    def __call__(self, value: int) -> int:
        if not 0 <= value < self.modulus:
            raise ValueError(f"{value} is not a {self.modulus.bit_length() - 1}-bit counter value")
        last = self._last
        if last is not None:
            delta = value - last
            if delta < -self._half:
                self._base += self.modulus
                self.wraps += 1
            elif delta > self._half and self._base:
                # A late value from just before the last wrap.
                return self._base - self.modulus + value
        self._last = value
        return self._base + value


@dataclass(frozen=True, slots=True)
class ClockFit:
    """host_s = host_ref + (device_us - device_ref) * 1e-6 * (1 + skew)."""

    device_ref: int
    host_ref: float
    skew: float
    points: int

    def to_host(self, device_us: int) -> float:
        return self.host_ref + (device_us - self.device_ref) * 1e-6 * (1.0 + self.skew)

    def to_device(self, host_s: float) -> float:
        return self.device_ref + (host_s - self.host_ref) / (1e-6 * (1.0 + self.skew))


class ClockSync:
    """Sliding-window estimate of the device-to-host clock mapping.

    ``window_s``: how much history the fit uses (longer = less noise, slower to follow
    temperature drift). ``bin_s``: each bin contributes its earliest arrival. ``max_skew``:
    rates further off than this are rejected as nonsense (a reset or a bad clock).
    ``min_span_s``: below this much history the rate is taken as nominal, because a slope
    fitted over a second or two of jittery arrivals is worse than assuming 0 ppm.
    """

    def __init__(self, window_s: float = 20.0, bin_s: float = 0.25, max_skew: float = 2e-3,
                 refit_every: int = 64, min_span_s: float = 4.0) -> None:
        # No step detection (step_s = inf): see the module's docstring.
        self._clock = FrameClock(1e6, window_s=window_s, bin_s=bin_s, max_skew=max_skew,
                                 min_span_s=min_span_s, refit_every=refit_every,
                                 step_s=math.inf)
        self._unwrap = Unwrapper()
        self.resets = 0

    @property
    def fit(self) -> ClockFit | None:
        """The current mapping (None before the first observation)."""
        c = self._clock
        if not c.ready:
            return None
        ref_x, ref_lag = c.reference
        return ClockFit(round(ref_x * 1e6), ref_x + ref_lag, c.skew, c.points)

    def reset(self) -> None:
        """Forget everything (after a device reset its clock restarts)."""
        self._unwrap.reset()
        self._clock.reset()
        self.resets += 1

    def unwrap(self, device_us_u32: int) -> int:
        return self._unwrap(device_us_u32)

    def observe(self, device_us_u32: int, host_s: float) -> int:
        """Record one arrival; returns the unwrapped device time in microseconds."""
        d = self._unwrap(device_us_u32)
        self._clock.observe(d, host_s)
        return d

    def to_host(self, device_us: int) -> float:
        """Host monotonic seconds of an unwrapped device time (needs one observation)."""
        return self._clock.to_host(device_us)
