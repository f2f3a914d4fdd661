"""Map device microseconds to host monotonic seconds. Pure: the caller supplies both clocks.

A frame's host arrival time is its device time mapped through an unknown offset and rate
(the Uno's resonator runs up to a few hundred ppm off), plus a transport delay that is never
negative and usually near its minimum. So the mapping is fitted to the *lower envelope* of
(device time, arrival time) pairs over a sliding window: the earliest arrivals in each short
bin, through which a least-squares line gives rate and offset. Arrival jitter then does not
bias the map, only the minimum delay remains in it (a constant, the same for every frame).
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass


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
        if window_s <= 2 * bin_s:
            raise ValueError("window_s must span several bins")
        self.window_s = window_s
        self.bin_s = bin_s
        self.max_skew = max_skew
        self.refit_every = refit_every
        self.min_span_s = min_span_s
        self._unwrap = Unwrapper()
        # Each bin: [bin index, device_us, host_s - device_s] of its earliest arrival.
        self._bins: deque[list[float]] = deque()
        self._fit: ClockFit | None = None
        self._since_fit = 0
        self.resets = 0

    @property
    def fit(self) -> ClockFit | None:
        return self._fit

    def reset(self) -> None:
        """Forget everything (after a device reset its clock restarts)."""
        self._unwrap.reset()
        self._bins.clear()
        self._fit = None
        self._since_fit = 0
        self.resets += 1

    def unwrap(self, device_us_u32: int) -> int:
        return self._unwrap(device_us_u32)

    def observe(self, device_us_u32: int, host_s: float) -> int:
        """Record one arrival; returns the unwrapped device time in microseconds."""
        if not math.isfinite(host_s):
            raise ValueError("host time must be finite")
        d = self._unwrap(device_us_u32)
        lag = host_s - d * 1e-6
        b = math.floor(d * 1e-6 / self.bin_s)
        bins = self._bins
        changed = False
        if bins and bins[-1][0] == b:
            if lag < bins[-1][2]:
                bins[-1][1] = d
                bins[-1][2] = lag
                changed = True
        else:
            bins.append([b, d, lag])
            changed = True
            while bins and (b - bins[0][0]) * self.bin_s > self.window_s:
                bins.popleft()
        self._since_fit += 1
        # Refit only when the lower envelope moved (a new bin, or a new minimum in the last
        # one) and at least every refit_every points: most frames cost no fit at all.
        fit = self._fit
        if fit is None or self._since_fit >= self.refit_every or (
                changed and (len(bins) < 3 or host_s < fit.to_host(d))):
            self._refit()
        elif changed and self._since_fit >= 8:
            self._refit()
        return d

    def _refit(self) -> None:
        self._since_fit = 0
        bins = self._bins
        n = len(bins)
        if n == 0:
            return
        d0 = bins[-1][1]
        if n < 3:
            # Too little history for a rate: assume nominal rate through the best point.
            best = min(bins, key=lambda x: x[2])
            self._fit = ClockFit(int(best[1]), best[2] + best[1] * 1e-6, 0.0, n)
            return
        # Least squares of lag (host - device seconds) against device seconds, relative to
        # the newest point for conditioning (device times reach 1e10 us and beyond).
        xs = [(x[1] - d0) * 1e-6 for x in bins]
        ys = [x[2] for x in bins]
        mx = sum(xs) / n
        my = sum(ys) / n
        sxx = sum((x - mx) ** 2 for x in xs)
        sxy = sum((x - mx) * (y - my) for x, y in zip(xs, ys, strict=True))
        slope = sxy / sxx if sxx > 0 else 0.0
        if abs(slope) > self.max_skew or -xs[0] < self.min_span_s:
            slope = 0.0
        # Lower envelope: shift the line down to touch the earliest arrival.
        intercept = min(y - slope * x for x, y in zip(xs, ys, strict=True))
        self._fit = ClockFit(int(d0), d0 * 1e-6 + intercept, slope, n)

    def to_host(self, device_us: int) -> float:
        """Host monotonic seconds of an unwrapped device time (needs one observation)."""
        if self._fit is None:
            raise RuntimeError("no clock observations yet")
        return self._fit.to_host(device_us)
