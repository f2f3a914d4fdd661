"""The paper's cup protocol on the simulated hand: count rims by vibration, lift 1-3 cups."""
from __future__ import annotations

import numpy as np
import pytest

from fingertip.tasks.cups import CupConfig, count_rims, unstack
from fingertip.sim.experiment import cups_table, run_cups
from fingertip.sim.world.cups import approach_height, make_cup_world

TRIALS = 12
"""A third of the paper's 36: every target, every rim; `make bench` runs all 36
(`cups_success`, goal 36/36)."""


def test_cup_trials_count_and_lift():
    r = run_cups(TRIALS, seed=0)
    s = r.summary()
    assert s["failure_modes"] == {}, [t for t in r.trials if t["failure"]]
    assert (s["counted"], s["lifted"], s["success"]) == (TRIALS, TRIALS, TRIALS)
    assert all(v["trials"] > 0 for v in s["per_target"].values())   # targets 1, 2 and 3
    assert all(t["rims_passed"] == 3 for t in r.trials)              # 21 mm over three rims
    assert max(t["rim_height_error_mm"] for t in r.trials) < 0.3
    assert f"| counted and lifted (the paper's 36/36) | {TRIALS}/{TRIALS} |" in cups_table(r)


def test_rim_heights_come_from_the_arms_log():
    world, hand, arm = make_cup_world(5)
    arm.move_to(0.0, 0.0, approach_height(world))
    rims = count_rims(hand, arm, CupConfig(slide_speed_mm_s=12.0))
    truth = world.stack.rims_mm()[:3]
    assert rims.count == 3
    assert np.allclose(rims.heights_mm, truth, atol=0.3)
    assert rims.pitch_mm == pytest.approx(world.stack.pitch_mm, abs=0.6)


@pytest.mark.parametrize("config, mode", [
    ({"threshold": 0.5}, "miscounted (too few rims)"),  # tau far above any rim's RMS
    ({"k": 0.5}, "miscounted"),                          # tau in the scrape: rims merge
    ({"strokes": 0}, "not separated"),                   # no alternating finger strokes
    ({"grasp_below": 0.05}, "grasp on a rim"),          # pinches the target's lip
])
def test_wrong_settings_fail_and_are_counted(config, mode):
    r = run_cups(6, seed=100, **config)
    modes = r.summary()["failure_modes"]
    assert r.success < 6 and any(m.startswith(mode) for m in modes), modes
    assert sum(modes.values()) == 6 - r.success


def test_grasp_above_the_stack_touches_nothing():
    world, hand, arm = make_cup_world(3)
    arm.move_to(0.0, 0.0, approach_height(world))
    cfg = CupConfig(grasp_below=-1.0)       # "below" the top rim by minus one pitch: above it
    cfg.grip.timeout_s = 2.0
    r = unstack(hand, arm, 1, cfg)
    assert r.failure == "timeout" and world.lifted_cups() == 0
    assert all(p == 0 for p in hand.positions().values())


def test_recipe_needs_a_target():
    world, hand, arm = make_cup_world(0)
    with pytest.raises(ValueError):
        unstack(hand, arm, 0)


def test_a_robot_without_audio_or_z_log_is_refused_before_anything_moves():
    from fingertip.tasks.interfaces import RobotArm, RobotHand

    world, hand, arm = make_cup_world(2)
    arm.move_to(0.0, 0.0, approach_height(world))
    start = arm.position()

    class DeafHand(type(hand)):
        read_audio = RobotHand.read_audio
        step_z = RobotHand.step_z

    class ArmWithoutLog(type(arm)):
        z_history = RobotArm.z_history

    hand.__class__, arm.__class__ = DeafHand, ArmWithoutLog
    with pytest.raises(NotImplementedError, match=r"unstacking cups needs DeafHand\.read_audio, "
                       r"DeafHand\.step_z, ArmWithoutLog\.z_history: implement them"):
        unstack(hand, arm, 2)
    assert arm.position() == start and not arm.moving()
    assert all(p == 0.0 for p in hand.positions().values())
