"""The sensor as the firmware's inputs, a block of conversions ahead: the same values as one
conversion at a time, whatever the device asks and however the scene changes meanwhile."""
from __future__ import annotations

import numpy as np
import pytest

from fingertip.sim.device.bringup import GuidedScene
from fingertip.sim.physics.scenes import Idle
from fingertip.sim.physics.strain import VirtualStrainSensor

PERIOD_US = 12_500


def _session(lookahead: int, rate_sps: int | None) -> tuple[np.ndarray, object]:
    """3000 conversions of a guided unit: a press and taps added while it runs (as the
    bring-up check's guide does), a 100 ms gap (10 SPS noise), a conversion 3 us late."""
    scene = GuidedScene()
    src = VirtualStrainSensor(3).as_source(scene, rate_sps=rate_sps, lookahead=lookahead)
    out, t = [], 0
    for k in range(3000):
        now = t * 1e-6
        if k == 400:
            scene.press(now + 0.25, 30.0)
        if k == 1200:
            scene.tap([now + 0.1, now + 0.3])
        if k == 1900:       # a press that starts inside the block already served
            scene.press(now + 0.02, 200.0)
        t += 100_000 if 2000 <= k < 2100 else PERIOD_US
        if k == 2500:
            t += 3
        out.append(src(t))
    return np.array(out), src


@pytest.mark.parametrize("rate_sps", [None, 80])
def test_a_block_ahead_gives_what_one_at_a_time_gives(rate_sps):
    one, _ = _session(1, rate_sps)
    ahead, src = _session(32, rate_sps)
    assert np.ptp(one[:, 0]) > 1e4          # the presses and taps are in the signal
    # The same noise draws and load history: equal up to rounding between batch sizes.
    np.testing.assert_allclose(ahead, one, rtol=0, atol=1e-6)
    assert np.array_equal(np.rint(ahead), np.rint(one))
    # Each scene change, the gap and the late conversion gave up a block; most were whole.
    assert 4 <= src.rewinds <= 12
    assert src.blocks < 3000 / 32 + 3 * src.rewinds + 10


def test_a_steady_stream_runs_the_physics_once_a_block():
    src = VirtualStrainSensor(0).as_source(Idle(duration=1e9), lookahead=32)
    for k in range(1, 32 * 10 + 2):
        src(k * PERIOD_US)
    # The first call knows no period (a block of one); then one batch per 32.
    assert (src.blocks, src.rewinds) == (11, 0)


def test_restored_state_repeats_the_same_conversions():
    sensor = VirtualStrainSensor(5)
    xy = np.tile([[1.5, -0.5]], (50, 1))
    t = np.arange(1, 51) * PERIOD_US * 1e-6
    sensor.raw_counts_batch(xy[:10], 2.0, t[:10])
    saved = sensor.save_state()
    first = sensor.raw_counts_batch(xy[10:], 2.0, t[10:])
    sensor.restore_state(saved)
    again = sensor.raw_counts_batch(xy[10:], 2.0, t[10:])
    assert np.array_equal(first, again)


def test_times_going_back_are_refused_as_before():
    src = VirtualStrainSensor(0).as_source(Idle(duration=1e9))
    for k in range(1, 5):
        src(k * PERIOD_US)
    with pytest.raises(ValueError, match="backwards"):
        src(PERIOD_US)


def test_lookahead_must_be_positive():
    with pytest.raises(ValueError, match="lookahead"):
        VirtualStrainSensor(0).as_source(Idle(duration=1e9), lookahead=0)
