"""Bring your own robot: fingertips attached by body names to a hand generated here."""
from __future__ import annotations

import math
import sys

import mujoco
import numpy as np
import pytest

from fingertip.sim.mujoco import FingertipSensor, attach_fingertips
from fingertip.sim.mujoco.drive import run

FINGERS = 3
RADIUS = 0.045


def _hand_xml() -> str:
    """A palm with three fingers at 120 degrees, each a hinge and a link, over a cylinder."""
    fingers, motors = [], []
    for k in range(FINGERS):
        a = 2 * math.pi * k / FINGERS
        c, s = math.cos(a), math.sin(a)
        fingers.append(f'''
      <body name="f{k}_base" pos="{RADIUS * c} {RADIUS * s} 0">
        <joint name="f{k}" type="hinge" axis="{-s} {c} 0" range="-0.1 0.6" damping="0.05"/>
        <body name="f{k}_distal" pos="0 0 -0.05">
          <geom type="box" size="0.006 0.006 0.025" pos="0 0 0.025" mass="0.02"/>
        </body>
      </body>''')
        motors.append(f'<position joint="f{k}" kp="2" kv="0.05" ctrlrange="-0.1 0.6"/>')
    return f"""
<mujoco><compiler angle="radian"/>
  <option timestep="0.002" cone="elliptic" impratio="10" gravity="0 0 0"/>
  <worldbody>
    <body name="palm" pos="0 0 0.1">{"".join(fingers)}</body>
    <body name="can" pos="0 0 0.05"><freejoint/>
      <geom type="cylinder" size="0.02 0.03" mass="0.05"/></body>
  </worldbody>
  <actuator>{"".join(motors)}</actuator>
</mujoco>"""


def _quat_facing(angle: float) -> np.ndarray:
    """Fingertip +z down, its -x face towards the palm's axis from a finger at ``angle``."""
    c, s = math.cos(angle), math.sin(angle)
    x, z = np.array([c, s, 0.0]), np.array([0.0, 0.0, -1.0])
    mat = np.column_stack([x, np.cross(z, x), z])
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, mat.reshape(-1))
    return q


def test_fingertips_on_a_generated_three_finger_hand_feel_the_grasp():
    spec = mujoco.MjSpec.from_string(_hand_xml())
    tips = {}
    for k in range(FINGERS):  # each finger's frame is turned: one call per finger here
        tips.update(attach_fingertips(spec, [f"f{k}_distal"],
                                      quat=tuple(_quat_facing(2 * math.pi * k / FINGERS))))
    m = spec.compile()
    d = mujoco.MjData(m)
    sensors = {b: FingertipSensor(m, d, t, fidelity="strain") for b, t in tips.items()}

    def close(t: float, data) -> None:
        data.ctrl[:] = 0.5 * min(1.0, t / 0.5)

    run(m, d, list(sensors.values()), 1.5, close)
    for s in sensors.values():
        force, height = s.wrench()
        assert force[0] > 0.1          # the can pushes each fingertip's face outwards
        assert abs(force[1]) < 0.2 * force[0]
        counts = np.array([r.counts for r in s.readings()])
        assert np.ptp(counts[:, 0] - counts[:, 2]) > 10_000  # and the gauges see it


def test_attaching_by_a_wrong_body_name_adds_nothing():
    spec = mujoco.MjSpec.from_string(_hand_xml())
    n = len(spec.bodies)
    with pytest.raises(ValueError, match="no body 'f9_distal' in the model"):
        attach_fingertips(spec, ["f0_distal", "f9_distal"])
    assert len(spec.bodies) == n


def test_without_the_extra_one_line_says_which_to_install(monkeypatch):
    from fingertip.sim.mujoco import _require

    monkeypatch.setitem(sys.modules, "mujoco", None)  # as if `pip install mujoco` never ran
    with pytest.raises(ImportError) as e:
        _require.mujoco()
    assert str(e.value) == "MuJoCo is not installed: pip install 'fingertip[mujoco]'"
