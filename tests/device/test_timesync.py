"""Device-to-host clock mapping: drift, jitter, and the 32-bit microsecond wraparound."""
from __future__ import annotations

import random

import pytest

from fingertip.device import ClockSync, Unwrapper

U32 = 1 << 32


def test_unwrap_across_wrap_and_late_values():
    u = Unwrapper()
    assert u(U32 - 10) == U32 - 10
    assert u(5) == U32 + 5
    assert u.wraps == 1
    assert u(U32 - 3) == U32 - 3  # a late value from before the wrap
    assert u(100) == U32 + 100
    assert u(U32 // 2) == U32 + U32 // 2
    assert u(U32 - 5) == 2 * U32 - 5
    assert u(3) == 2 * U32 + 3
    with pytest.raises(ValueError):
        u(U32)
    with pytest.raises(ValueError):
        u(-1)


@pytest.mark.parametrize("skew_ppm", [-100.0, 0.0, 100.0])
def test_mapping_follows_drift_and_ignores_jitter(skew_ppm):
    rng = random.Random(int(skew_ppm) + 7)
    sync = ClockSync()
    skew = skew_ppm * 1e-6
    start_dev = U32 - 30_000_000  # wraps 30 s into the run
    host0 = 1234.5
    min_delay = 0.0012
    errors = []
    for k in range(80 * 120):  # 2 minutes at 80 Hz
        dev = start_dev + k * 12_500
        true_host = host0 + (dev - start_dev) * 1e-6 * (1 + skew)
        arrival = true_host + min_delay + rng.expovariate(1 / 0.002)  # USB/UART jitter
        d = sync.observe(dev % U32, arrival)
        assert d == dev
        if k > 80 * 15:
            errors.append(sync.to_host(d) - (true_host + min_delay))
    worst = max(abs(e) for e in errors)
    assert worst < 0.5e-3, worst
    assert abs(sync.fit.skew - skew) < 20e-6


def test_reset_restarts_and_counts():
    sync = ClockSync()
    sync.observe(1_000_000, 10.0)
    sync.reset()
    assert sync.fit is None and sync.resets == 1
    with pytest.raises(RuntimeError):
        sync.to_host(0)
    sync.observe(0, 20.0)
    assert sync.to_host(0) == pytest.approx(20.0)


def test_rejects_nan_host_time():
    with pytest.raises(ValueError):
        ClockSync().observe(0, float("nan"))


@pytest.mark.parametrize("late_s", [0.2, 1.0])
def test_frames_that_keep_arriving_late_do_not_move_the_mapping(late_s):
    """A reader or a simulator that falls behind and stays behind (frames arrive at their
    pace, but ``late_s`` after they were made) delays transport, not the device's clock: the
    map keeps mapping each device time to when it happened. The device's microsecond counter
    cannot step forward against the host's without a reset (handled apart), so a late stretch
    is never taken for a step of the clock."""
    rng = random.Random(3)
    sync = ClockSync()
    host0, min_delay = 50.0, 0.0012
    errors = []
    for k in range(80 * 30):  # 30 s at 80 Hz; from 15 s on, every frame comes late_s late
        dev = k * 12_500
        true_host = host0 + dev * 1e-6
        arrival = true_host + min_delay + rng.expovariate(1 / 0.002)
        if k >= 80 * 15:
            arrival += late_s
        d = sync.observe(dev, arrival)
        if k >= 80 * 15:
            errors.append(sync.to_host(d) - (true_host + min_delay))
    worst = max(abs(e) for e in errors)
    assert worst < 0.5e-3, worst
