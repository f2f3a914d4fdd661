"""The pinch that approaches at a set speed: the recipe with a contact source, on the simulated
hand with speed-controlled fingers, force frames at 15/80 Hz and piezos."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fingertip.events.contact_set import ContactSet
from fingertip.events.reflex import OnsetDetector
from fingertip.sim import pinch_speed as ps
from fingertip.sim.world.approach_hand import ACCEL_MM_S2, COMMAND_S, ApproachHand
from fingertip.tasks import PinchConfig, PinchOutcome, pinch
from fingertip.sim.world.hand import CHIP, FINGERS, TOFU, make_world


def _hand(rate=80.0, spec=TOFU, seed=3):
    return make_world(spec, seed, hand_factory=lambda w, u: ApproachHand(w, u, rate, seed))


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


def test_read_waits_at_most_its_timeout_and_frames_come_at_the_rate():
    world, hand, _ = _hand(rate=15.0)
    t0 = world.t_s
    assert hand.read(0.001) is None
    assert world.t_s == pytest.approx(t0 + 0.001)
    frames = hand.read(0.5)
    assert frames is not None and set(frames) == set(FINGERS)
    assert world.t_s == pytest.approx(t0 + 1 / 15)
    assert frames["f0"].host_time == pytest.approx(world.t_s)
    hand.read(0.5)
    assert world.t_s == pytest.approx(t0 + 2 / 15)
    with pytest.raises(ValueError, match="frame rate"):
        ApproachHand(world, {f: 100 + i for i, f in enumerate(FINGERS)}, rate_hz=0)


def test_a_move_starts_after_the_command_delay_and_brakes_at_the_set_rate():
    world, hand, _ = _hand()
    world.obj.gaps_mm["f0"] = 25.0                   # nothing to touch
    hand.move({"f0": 20.0})
    for _ in range(8):
        hand.read(0.5)                               # 0.1 s
    v, t = 20.0, 0.1 - COMMAND_S
    ramp = v / ACCEL_MM_S2
    assert world.positions["f0"] == pytest.approx(v * (t - ramp / 2), rel=1e-3)
    assert world.positions["f1"] == 0.0
    before = world.positions["f0"]
    hand.move({"f0": 0.0})
    hand.read(0.5)
    # Still moving for the command delay, then braking over v / a.
    assert world.positions["f0"] - before == pytest.approx(
        v * COMMAND_S + v * v / (2 * ACCEL_MM_S2), rel=1e-3)
    with pytest.raises(ValueError, match="no finger"):
        hand.move({"thumb": 1.0})


def test_the_piezo_hears_the_touch_when_it_happens_in_contiguous_blocks():
    world, hand, _ = _hand(seed=5)
    world.obj.gaps_mm["f2"] += 16.0 * ps.PRE_S         # at speed, past the gate
    blocks = [hand.read_audio("f2")]
    hand.move({"f2": 16.0})
    det = OnsetDetector(hand.fs)
    det.gate(world.t_s, world.t_s + 0.08)              # the motor spinning up
    onsets = []
    while world.t_s < 1.4:
        hand.read(64 / hand.fs)
        b = hand.read_audio("f2")
        assert b.t0 == pytest.approx(blocks[-1].t_end, abs=0.5 / hand.fs)
        blocks.append(b)
        onsets += det.feed(b.samples, b.t0)
    truth = hand.contact_s["f2"]
    assert len(onsets) >= 1
    assert onsets[0][0] == pytest.approx(truth, abs=0.0015), (onsets, truth)
    x = np.concatenate([b.samples for b in blocks])
    assert x.dtype == np.float32 and np.isfinite(x).all()


def test_pinch_refuses_a_hand_without_speed_moves():
    world, hand, arm = make_world(TOFU, 0)          # the plain SimHand
    with pytest.raises(NotImplementedError, match="SimHand.move"):
        pinch(hand, arm, PinchConfig(0.5, step_mm=0.05, approach_speed_mm_s=4.0))
    assert all(p == 0.0 for p in hand.positions().values())


def test_an_approach_that_never_touches_times_out_stopped_and_open():
    world, hand, arm = _hand()
    for f in FINGERS:
        world.obj.gaps_mm[f] = 29.0
    cfg = PinchConfig(0.5, step_mm=0.05, approach_speed_mm_s=2.0, timeout_s=0.5)
    r = pinch(hand, arm, cfg, ContactSet(hand.fingers, "force"))
    assert r.outcome is PinchOutcome.TIMEOUT, r.detail
    assert all(p == 0.0 for p in hand.positions().values())
    hand.read(0.5)
    assert all(p == 0.0 for p in hand.positions().values())   # no move left running


def test_contact_set_refuses_bad_input():
    with pytest.raises(ValueError, match="contact mode"):
        ContactSet(["f0"], "sonar")
    with pytest.raises(ValueError, match="sample rate"):
        ContactSet(["f0"], "fused")
    with pytest.raises(ValueError, match="no fingers"):
        ContactSet([], "force")
    cs = ContactSet(["f0"], "force")
    assert not cs.needs_audio
    with pytest.raises(ValueError, match="no finger"):
        cs.feed_force("f9", 0.0, 0.0)
    with pytest.raises(ValueError, match="not finite"):
        cs.feed_force("f0", 0.0, math.nan)
    assert cs.feed_audio("f0", np.zeros(64), 0.0) == []


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
