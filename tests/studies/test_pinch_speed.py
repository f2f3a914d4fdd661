"""The pinch-speed study (studies/pinch_speed.py): detectors at approach speed on the
simulated hand."""
from __future__ import annotations

import pytest

from fingertip.sim.world.hand import CHIP
from studies import pinch_speed as ps


def test_fused_contact_stops_within_milliseconds_and_keeps_the_chip():
    for seed in range(3):
        t = ps.pinch_trial("chip", 8.0, seed, "fused")
        assert t.success, (seed, t.outcome, t.peak_true_n)
        assert t.sources == ["piezo"] * 4, t.sources
        # Heard within an audio block or two (+1 ms audio path), not a force frame (12.5 ms).
        assert len(t.detect_ms) == 4 and max(t.detect_ms) < 6.0, t.detect_ms
        assert t.peak_true_n < CHIP.crush_n


def test_force_frames_at_15_hz_overshoot_and_crush_the_chip_at_the_same_speed():
    t = ps.pinch_trial("chip", 8.0, 0, "force15")
    assert not t.success and t.broken, t.outcome
    assert t.peak_true_n > CHIP.crush_n
    # The force detector knows only at a frame: tens of milliseconds after the touch.
    assert min(t.detect_ms) > 12.0, t.detect_ms
    slow = ps.pinch_trial("chip", 0.5, 0, "force15")
    assert slow.success, slow.outcome


def test_sweep_stops_a_detector_after_a_speed_that_always_breaks():
    res = ps.sweep([0.5, 8.0, 16.0], trials=1, seed=0, modes=("force15",))
    assert res["force15"][0.5] == {"tofu": 1, "chip": 1}
    assert res["force15"][8.0]["chip"] == 0
    assert 16.0 not in res["force15"]
    assert ps.max_safe_speed(res["force15"], 1) == 0.5
    assert "0.5 mm/s" in ps.table(res, 1)
    with pytest.raises(ValueError, match="speeds"):
        ps.sweep([0.0], trials=1)
    with pytest.raises(ValueError, match="mode"):
        ps.pinch_trial("chip", 1.0, 0, "radar")
