"""Holding with the slip reflex (tasks/hold.py unchanged) on the sideways MuJoCo gripper."""
from __future__ import annotations

from fingertip.sim.mujoco.hold_trials import hold_trial


def test_a_sudden_load_drops_the_box_without_a_reflex_and_the_reflex_keeps_it():
    none = hold_trial(4, "none")          # a cardboard box, 0.5 x its mass added in 5 ms
    fused = hold_trial(4, "fused")
    assert none["ok"] and fused["ok"]
    assert not none["held"] and none["slid_mm"] > 5.0
    assert fused["held"] and fused["slid_mm"] < 2.0
    assert fused["slip_events"] >= 1 and fused["false_before_load"] == 0
    assert fused["mean_grip_n"] > none["mean_grip_n"]
