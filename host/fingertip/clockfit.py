"""Map a free-running counter's clock to the host clock: a lower-envelope fit. Pure.

Two clocks in this project run on their own crystals and only tell us, on arrival, that an
event "had happened by now": the sound card's ADC (frame counts) and the fingertip's
microcontroller (device microseconds). Both go through :class:`FrameClock`; the audio
sources (fingertip.audio) and the device clock map (fingertip.device.timesync) sit above it.

A sound card's ADC runs on its own crystal, up to a few hundred ppm off the host clock, so
frame ``k`` was digitised at ``t(k) = t0 + k / rate`` with ``rate`` near, not at, the nominal
sample rate. Each audio callback tells us that by its arrival time the block's last frame had
been captured, plus a delay that is never negative and usually near its minimum (server and
driver buffering, scheduling). So ``t(k)`` is fitted to the *lower envelope* of (frame index,
arrival) points over a sliding window: the earliest arrival of each short bin; the rate is
the slope of their lower convex hull where it passes the middle of the window's on-time bins,
the line touches the hull. Bursty callbacks (PulseAudio) and a backlog delivered late after a stall
then do not bias the times; only the minimum delay stays in them, a constant for the whole
stream. A device's frames are the same case: each arrives its transport delay after its
device time (index = microseconds, ``nominal_rate=1e6``).

The same class maps any clock to the host clock, e.g. PortAudio's stream clock (in seconds,
``nominal_rate=1``) to ``time.monotonic()``. It is pure: the caller supplies both clocks.
"""
from __future__ import annotations

import math
from collections import deque
from itertools import pairwise


LATE_S = 0.05
"""A bin whose earliest point lies this far above the fitted line came late (a backlog): it
still bounds the line from below, but it does not choose where the rate is read."""


class FrameClock:
    """Sliding-window lower-envelope estimate of ``host_time(index)``.

    ``nominal_rate``: index units per second (the sample rate). ``window_s``: history used
    by the fit. ``bin_s``: each bin contributes its earliest point. ``max_skew``: rates
    further off than this are taken as nominal. ``min_span_s``: below this much history the
    rate is taken as nominal. ``step_s``: when every point of the last ``step_bins`` bins
    arrives more than this later than the fit, for at least half as long in host time, the
    stream has jumped (frames lost upstream without a flag, a suspended machine): history is
    dropped and ``steps`` counted (``math.inf``: never). The fit is redone when a point falls
    under the line, at least every ``refit_every`` points, and at each completed bin of the
    first few (cheap enough for a callback).
    """

    def __init__(self, nominal_rate: float, *, window_s: float = 20.0, bin_s: float = 0.25,
                 max_skew: float = 2e-3, min_span_s: float = 4.0, refit_every: int = 64,
                 step_s: float = 0.05, step_bins: int = 4) -> None:
        if not nominal_rate > 0:
            raise ValueError("nominal_rate must be positive")
        if window_s <= 2 * bin_s:
            raise ValueError("window_s must span several bins")
        self.nominal_rate = float(nominal_rate)
        self.window_s = window_s
        self.bin_s = bin_s
        self.max_skew = max_skew
        self.min_span_s = min_span_s
        self.refit_every = refit_every
        self.step_s = step_s
        self.step_bins = step_bins
        # Each bin: [bin number, index, lag = host - index / nominal_rate, host] of its lowest
        # point.
        self._bins: deque[list[float]] = deque()
        self._since_fit = 0
        self._have_fit = False
        self._ref_x = 0.0  # nominal seconds of the fit's reference point
        self._ref_lag = 0.0
        self._skew = 0.0  # d(lag)/d(nominal seconds): host seconds per nominal second - 1
        self.points = 0
        self.steps = 0

    @property
    def ready(self) -> bool:
        return self._have_fit

    @property
    def skew(self) -> float:
        """Host seconds per nominal second minus one (+100e-6: the card runs 100 ppm slow)."""
        return self._skew

    @property
    def reference(self) -> tuple[float, float]:
        """The fit's reference point: (index / nominal_rate, host time - that) there."""
        return self._ref_x, self._ref_lag

    @property
    def rate(self) -> float:
        """Index units per host second (the measured sample rate, in host time)."""
        return self.nominal_rate / (1.0 + self._skew)

    def reset(self) -> None:
        self._bins.clear()
        self._have_fit = False
        self._since_fit = 0
        self._skew = 0.0

    def observe(self, index: float, host_time: float) -> None:
        """Index ``index`` had happened by ``host_time`` (an upper bound, usually close)."""
        if not math.isfinite(host_time):
            raise ValueError("host time must be finite")
        x = index / self.nominal_rate
        lag = host_time - x
        b = math.floor(x / self.bin_s)
        bins = self._bins
        self.points += 1
        new_bin = False
        if bins and bins[-1][0] == b:
            last = bins[-1]
            if lag < last[2]:
                last[1] = index
                last[2] = lag
                last[3] = host_time
        elif bins and b < bins[-1][0]:
            # Index went backwards: a new stream. Start over.
            bins.clear()
            bins.append([b, index, lag, host_time])
            self._have_fit = False
        else:
            if self._have_fit and self._stepped():
                self.steps += 1
                keep = list(bins)[-self.step_bins:]
                bins.clear()
                bins.extend(keep)
            bins.append([b, index, lag, host_time])
            new_bin = True  # the previous bin is complete: refit with it
            while bins and (b - bins[0][0]) * self.bin_s > self.window_s:
                bins.popleft()
        self._since_fit += 1
        # A completed bin only moves the fit while the history is short; later the periodic
        # refit (every refit_every points) follows drift, and a point under the line (the
        # envelope moved down) refits at once. Each refit walks every bin: doing it per bin
        # was half the bridge's per-frame work.
        if (not self._have_fit or (new_bin and len(bins) <= 4)
                or self._since_fit >= self.refit_every or lag < self._lag_at(x) - 1e-4):
            self._refit()

    def to_host(self, index: float) -> float:
        """Host time of ``index`` (needs at least one observation)."""
        if not self._have_fit:
            raise RuntimeError("no clock observations yet")
        x = index / self.nominal_rate
        return x + self._lag_at(x)

    # --- internals ------------------------------------------------------------------------

    def _lag_at(self, x: float) -> float:
        return self._ref_lag + self._skew * (x - self._ref_x)

    def _stepped(self) -> bool:
        """Whether the last ``step_bins`` closed bins all lie ``step_s`` above the fit, over
        a long enough stretch of host time: a backlog delivered in a burst after a stall
        (late, but nothing lost) comes in far less host time than it spans in frames."""
        bins = self._bins
        if len(bins) <= self.step_bins:
            return False
        if bins[-1][3] - bins[-self.step_bins][3] < 0.5 * (self.step_bins - 1) * self.bin_s:
            return False
        for i in range(1, self.step_bins + 1):
            _, index, lag, _ = bins[-i]
            x = index / self.nominal_rate
            if lag - self._lag_at(x) <= self.step_s:
                return False
        return True

    def _refit(self) -> None:
        self._since_fit = 0
        bins = self._bins
        n = len(bins)
        if n == 0:
            return
        x0 = bins[-1][1] / self.nominal_rate
        xs = [b[1] / self.nominal_rate - x0 for b in bins]
        ys = [b[2] for b in bins]
        slope = 0.0
        if n >= 3 and -xs[0] >= self.min_span_s:
            # The hull's edge is taken where the points' mean lies. Bins far above the current
            # line (a backlog, frames that keep coming late) would drag that mean onto a short,
            # noisy edge at the end of the on-time history, so only the others place it.
            on_time = xs
            if self._have_fit:
                on_time = [x for x, y in zip(xs, ys, strict=True)
                           if y - self._lag_at(x0 + x) <= LATE_S] or xs
            slope = _hull_slope(xs, ys, sum(on_time) / len(on_time))
            if abs(slope) > self.max_skew:
                slope = 0.0
        # Touch the lowest point (with the hull slope, that is the hull edge itself).
        intercept = min(y - slope * x for x, y in zip(xs, ys, strict=True))
        self._ref_x = x0
        self._ref_lag = intercept
        self._skew = slope
        self._have_fit = True


def _hull_slope(xs: list[float], ys: list[float], mean_x: float | None = None) -> float:
    """Slope of the best line under all points: the lower convex hull's edge at ``mean_x``
    (default: the mean of ``xs``).

    Of all lines below every point, it minimises the mean gap to the points (the linear
    program of Moon, Skelly and Towsley, "Estimation and removal of clock skew from network
    delay measurements", 1999). Points above the hull (late arrivals, a backlog delivered
    after a stall) do not move it, unlike a least-squares slope. ``xs`` must increase.
    """
    hull: list[tuple[float, float]] = []
    for p in zip(xs, ys, strict=True):
        while len(hull) >= 2:
            (ax, ay), (bx, by) = hull[-2], hull[-1]
            # Drop b unless a -> b -> p turns counter-clockwise (b is below the chord a-p).
            if (bx - ax) * (p[1] - ay) - (by - ay) * (p[0] - ax) <= 0:
                hull.pop()
            else:
                break
        if not hull or p[0] > hull[-1][0]:
            hull.append(p)
        elif p[1] < hull[-1][1]:
            hull[-1] = p
    if len(hull) < 2:
        return 0.0
    if mean_x is None:
        mean_x = sum(xs) / len(xs)
    for (ax, ay), (bx, by) in pairwise(hull):
        if bx >= mean_x:
            return (by - ay) / (bx - ax)
    (ax, ay), (bx, by) = hull[-2], hull[-1]
    return (by - ay) / (bx - ax)
