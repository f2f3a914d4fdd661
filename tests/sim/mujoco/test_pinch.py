"""The pinch recipe of tasks/ unchanged on the MuJoCo gripper (RobotHand, RobotArm)."""
from __future__ import annotations

import pytest

from fingertip.sim.mujoco.experiment import pinch_trial


@pytest.mark.parametrize(("name", "f_th"), [("tofu", 0.44), ("chip", 0.088)])
def test_the_paper_pinch_holds_and_lifts_without_breaking(name, f_th):
    r = pinch_trial(name, f_th, seed=3)
    assert r["success"], r
    assert r["outcome"] == "held" and not r["broken"]
    assert r["lifted_mm"] > 18.0


def test_a_threshold_above_the_crush_force_breaks_the_tofu():
    r = pinch_trial("tofu", 2.0, seed=3)  # tofu breaks at 1.5 N
    assert r["broken"] and not r["success"]
