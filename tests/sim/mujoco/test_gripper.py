"""The MuJoCo gripper: two fingertips squeeze objects that break above their crush force."""
from __future__ import annotations

import pytest

from fingertip.sim.mujoco import FingertipSensor
from fingertip.sim.mujoco.drive import run
from fingertip.sim.mujoco.gripper import FINGER_KP, gripper
from fingertip.sim.physics import Realism

TOFU_TOP = 0.025
DOWN = -0.1 + 0.004  # the arm's descent: the fingertips' lower 5 mm beside the tofu's top


def _pinch(close_m: float) -> tuple[dict, dict]:
    sc = gripper(("tofu",))
    brk = sc.info["breakables"]
    sensors = {k: FingertipSensor(sc.model, sc.data, tip, fidelity="wrench",
                                  realism=Realism.none()) for k, tip in sc.tips.items()}

    def control(t: float, data) -> None:
        data.ctrl[2] = DOWN * min(1.0, t / 0.5)
        data.ctrl[3] = data.ctrl[4] = close_m * min(1.0, max(0.0, t - 0.6) / 0.8)
        brk.update(data)

    run(sc.model, sc.data, list(sensors.values()), 1.8, control)
    return {k: s.wrench() for k, s in sensors.items()}, brk.broken


def test_a_gentle_pinch_holds_the_tofu_on_the_fingertips_lower_5_mm():
    wrench, broken = _pinch(0.0235)  # 3 mm past the tofu's faces: about 0.9 N
    assert not broken["tofu"]
    for force, height in wrench.values():
        # The tofu pushes each fingertip's -x face (towards the object) outwards: +x.
        assert force[0] == pytest.approx(3e-3 * FINGER_KP, rel=0.25)
        assert abs(force[1]) < 0.05
        assert 0.0 <= height <= 5.0


def test_squeezing_past_the_crush_force_breaks_the_tofu():
    _, broken = _pinch(0.0275)  # 7 mm past: about 2 N, above tofu's 1.5 N
    assert broken["tofu"]


def test_unknown_objects_are_refused():
    with pytest.raises(ValueError, match="unknown object 'egg': one of tofu, chip"):
        gripper(("egg",))
