"""Frame-count clock: lower-envelope fit through jittery, bursty callback arrivals."""
from __future__ import annotations

import math
import random

import pytest

from fingertip.audio import FrameClock

FS = 44100.0


def simulate(clock: FrameClock, skew_ppm: float, seconds: float, *, block: int = 441,
             seed: int = 1, burst: int = 1, t0: float = 500.0, min_delay: float = 0.004,
             check_after: float = 15.0, step_at: float | None = None, step: float = 0.0):
    """Feed a card whose clock runs ``skew_ppm`` slow; return the errors after warm-up.

    Frame k is digitised at t0 + k / FS * (1 + skew). Each callback arrives after a delay
    of min_delay plus exponential jitter; ``burst`` > 1 delivers that many blocks at once
    (PulseAudio style). ``step_at``: from then on arrivals come ``step`` seconds later.
    """
    rng = random.Random(seed)
    skew = skew_ppm * 1e-6
    errors = []
    k = 0
    pending = []
    while k / FS < seconds:
        end = k + block
        true_end = t0 + end / FS * (1 + skew)
        pending.append(end)
        if len(pending) == burst:
            arrival = true_end + min_delay + rng.expovariate(1 / 0.002)
            if step_at is not None and k / FS >= step_at:
                arrival += step
            for e in pending:
                clock.observe(e, arrival)
            pending.clear()
            if k / FS > check_after:
                true_k = t0 + k / FS * (1 + skew) + min_delay
                if step_at is not None and k / FS >= step_at:
                    true_k += step
                errors.append(clock.to_host(k) - true_k)
        k = end
    return errors


@pytest.mark.parametrize("skew_ppm", [-100.0, 0.0, 100.0])
def test_follows_drift_and_ignores_jitter(skew_ppm):
    clock = FrameClock(FS)
    errors = simulate(clock, skew_ppm, 120.0, seed=int(skew_ppm) + 3)
    worst = max(abs(e) for e in errors)
    assert worst < 0.5e-3, worst
    assert clock.skew == pytest.approx(skew_ppm * 1e-6, abs=15e-6)
    assert clock.rate == pytest.approx(FS / (1 + skew_ppm * 1e-6), rel=15e-6)
    assert clock.steps == 0


def test_bursty_callbacks_do_not_bias_the_times():
    clock = FrameClock(FS)
    errors = simulate(clock, 80.0, 60.0, block=95, burst=24, seed=9)
    assert max(abs(e) for e in errors) < 0.5e-3


def test_frames_lost_upstream_show_as_a_step_and_the_fit_recovers():
    clock = FrameClock(FS)
    errors = simulate(clock, 50.0, 60.0, step_at=30.0, step=0.2, check_after=33.0, seed=5)
    assert clock.steps == 1
    assert max(abs(e) for e in errors) < 1e-3


def test_small_history_assumes_nominal_rate():
    clock = FrameClock(FS)
    clock.observe(4410, 10.1)
    assert clock.ready and clock.skew == 0.0
    assert clock.to_host(0) == pytest.approx(10.0)
    clock.observe(8820, 10.19)  # earlier than the line: the envelope moves down at once
    assert clock.to_host(8820) == pytest.approx(10.19)


def test_index_going_back_starts_over_and_bad_input_is_refused():
    clock = FrameClock(FS)
    with pytest.raises(RuntimeError):
        clock.to_host(0)
    for k in range(0, 441 * 400, 441):
        clock.observe(k, 1.0 + k / FS)
    clock.observe(0, 100.0)  # a new stream
    assert clock.to_host(0) == pytest.approx(100.0)
    with pytest.raises(ValueError):
        clock.observe(10, math.nan)
    with pytest.raises(ValueError):
        FrameClock(0)


def test_maps_a_stream_clock_in_seconds():
    """nominal_rate=1: PortAudio's stream clock (seconds) to time.monotonic()."""
    clock = FrameClock(1.0)
    rng = random.Random(2)
    for i in range(3000):
        cur = 1.7e9 + i * 0.01
        clock.observe(cur, cur - 1.7e9 + 42.0 + rng.expovariate(1 / 0.0005))
    assert clock.to_host(1.7e9 + 12.345) == pytest.approx(42.0 + 12.345, abs=2e-4)


def test_a_backlog_after_a_stall_does_not_bend_the_fit():
    """A stalled callback: 2 s of frames arrive late, in a burst, then normal again."""
    clock = FrameClock(FS)
    rng = random.Random(4)
    errors = []
    for i in range(int(40 * FS / 441)):
        k = i * 441
        arrival = 100.0 + (k + 441) / FS + 0.003 + rng.expovariate(1 / 0.001)
        if 20.0 <= k / FS < 22.0:
            arrival = max(arrival, 100.0 + 22.0)  # nothing delivered until the stall ends
        clock.observe(k + 441, arrival)
        if k / FS > 10:
            errors.append(clock.to_host(k) - (100.0 + k / FS + 0.003))
    assert clock.steps == 0
    assert abs(clock.skew) < 10e-6
    assert max(abs(e) for e in errors) < 0.3e-3
