"""A four-finger hand on the gantry arm, like the paper's DeltaHand: the cup and box scenes'.

The arm is the gripper's gantry (three servoed slide joints, gravity compensated; controls
0-2 its offsets from home in m). The palm carries four fingers ``f0`` .. ``f3`` at 0, 90,
180 and 270 degrees around its axis (``f0`` towards +x, ``f2`` opposite it), each on two
servoed slide joints: one closing towards the axis (0 = open, at ``OPEN_RADIUS``), one
vertical (+-5 mm: the cup recipe's separation strokes). Controls 3 + 2 k and 4 + 2 k:
finger ``fk``'s closing travel and height offset (m).

Each fingertip points down, its end leaning 12 degrees inwards, with its fingernail towards
the axis: the paper presses the nails on the box's sides to hear its contents better, and
its nail finger slides its nail down the cups' rims. A contact on the nail loads the prism
from the side opposite the one the force model is calibrated on (the paper's sweep: forces
at 0 +- 50 degrees): there the unit's model reads 0.6-0.85 of MuJoCo's force, so the grips
here are a little firmer than their thresholds say.
"""
from __future__ import annotations

import math

import numpy as np

from ._require import mujoco
from .attach import attach_fingertip, geometry
from .gripper import ARM_HOME_Z
from .scenes import Scene, header

FINGERS = ("f0", "f1", "f2", "f3")
OPEN_RADIUS = 0.06
"""Each finger's axis from the palm's axis when open (m)."""
LINK_LENGTH = 0.08
FINGER_KP = 300.0
"""Closing servo stiffness (N/m), the gripper's."""
Z_KP = 1000.0
"""Vertical servo stiffness (N/m): a stroke moves the finger, not the finger's grip."""
TRAVEL = 0.045
TILT = math.radians(12.0)
"""Each fingertip's end leans this far towards the axis, as the DeltaHand's fingers lean: a
wall that tapers outwards going up (a cup's, 9 degrees) meets the nail, not the fingertip's
upper part 14 mm above it, where the force model is not calibrated."""


def angle(finger: str) -> float:
    """The finger's direction from the palm's axis (radians)."""
    return FINGERS.index(finger) * math.pi / 2


def nail_inward_quat(theta: float, tilt: float = TILT) -> tuple[float, float, float, float]:
    """Fingertip +z down with its end ``tilt`` towards the axis, +x (the nail) towards the
    axis, for a finger at ``theta``."""
    c, s = math.cos(theta), math.sin(theta)
    inward = np.array([-c, -s, 0.0])
    z = -math.cos(tilt) * np.array([0.0, 0.0, 1.0]) + math.sin(tilt) * inward
    x = math.cos(tilt) * inward + math.sin(tilt) * np.array([0.0, 0.0, 1.0])
    mat = np.column_stack([x, np.cross(z, x), z])
    q = np.zeros(4)
    mujoco().mju_mat2Quat(q, mat.reshape(-1))
    return tuple(float(v) for v in q)


def _nail_edge() -> np.ndarray:
    """The nail's lower inner edge in finger f0's frame (m): x outwards, z up."""
    g = geometry()
    out = np.zeros(3)
    mujoco().mju_rotVecQuat(out, np.array([g.nail_x[1], 0.0, g.nail_tip_z]),
                            np.asarray(nail_inward_quat(0.0), float))
    return out + np.array([0.0, 0.0, -LINK_LENGTH])


def nail_radius_open() -> float:
    """The nail's lower inner edge from the palm's axis with the finger open (m)."""
    return OPEN_RADIUS + float(_nail_edge()[0])


def nail_low_z() -> float:
    """The nail's lower edge below the palm (m)."""
    return -float(_nail_edge()[2])


def hand4_xml(world: str, extra: str = "", timestep: float = 0.002,
              arm_z: float = ARM_HOME_Z) -> str:
    """The scene's MJCF: ``world`` (bodies and geoms in the worldbody), ``extra`` (sections
    after it: contact, equality, ...), the arm's home at height ``arm_z`` (m)."""
    fingers, motors = [], []
    for f in FINGERS:
        c, s = math.cos(angle(f)), math.sin(angle(f))
        fingers.append(f'''
      <body name="{f}" pos="{OPEN_RADIUS * c} {OPEN_RADIUS * s} 0" gravcomp="1">
        <joint name="{f}_close" type="slide" axis="{-c} {-s} 0" range="0 {TRAVEL}"
               damping="2"/>
        <joint name="{f}_z" type="slide" axis="0 0 1" range="-0.005 0.005" damping="6"/>
        <geom name="{f}_link" type="box" size="0.006 0.006 {LINK_LENGTH / 2}"
              pos="{0.012 * c} {0.012 * s} {-LINK_LENGTH / 2}" mass="0.05"
              rgba="0.5 0.5 0.55 1"/>
      </body>''')
        motors.append(f'''
    <position name="{f}_close" joint="{f}_close" kp="{FINGER_KP}" kv="8"
              ctrlrange="0 {TRAVEL}"/>
    <position name="{f}_z" joint="{f}_z" kp="{Z_KP}" kv="4" ctrlrange="-0.005 0.005"/>''')
    return header("fingertip_hand4", timestep, "table") + f"""
    {world}
    <body name="arm" pos="0 0 {arm_z}" gravcomp="1">
      <joint name="arm_x" type="slide" axis="1 0 0" damping="20"/>
      <joint name="arm_y" type="slide" axis="0 1 0" damping="20"/>
      <joint name="arm_z" type="slide" axis="0 0 1" damping="20"/>
      <geom name="palm" type="cylinder" size="0.07 0.008" mass="0.5" rgba="0.3 0.3 0.35 1"/>
      {"".join(fingers)}
    </body>
  </worldbody>
  {extra}
  <actuator>
    <position name="arm_x" joint="arm_x" kp="4000" kv="200" ctrlrange="-1 1"/>
    <position name="arm_y" joint="arm_y" kp="4000" kv="200" ctrlrange="-1 1"/>
    <position name="arm_z" joint="arm_z" kp="4000" kv="200" ctrlrange="-1 1"/>
    {"".join(motors)}
  </actuator>
</mujoco>"""


def hand4_spec(world: str, extra: str = "", timestep: float = 0.002,
               arm_z: float = ARM_HOME_Z):
    """The scene's ``MjSpec`` with its four fingertips attached (see :func:`hand4`)."""
    mj = mujoco()
    spec = mj.MjSpec.from_string(hand4_xml(world, extra, timestep, arm_z))
    tips = {}
    for f in FINGERS:
        tips[f] = attach_fingertip(spec, f, f"{f}_tip", pos=(0.0, 0.0, -LINK_LENGTH),
                                   quat=nail_inward_quat(angle(f)))
        spec.body(f"{f}_tip").gravcomp = 1.0
    return spec, tips


def compiled(spec, tips: dict, materials: dict | None = None, info: dict | None = None,
             arm_z: float = ARM_HOME_Z) -> Scene:
    """A :class:`Scene` of the compiled spec; ``scene.info`` says which actuators close and
    lift which finger (:class:`~.robot.MujocoWorld` reads it)."""
    mj = mujoco()
    model = spec.compile()
    data = mj.MjData(model)
    fingers = {f: 3 + 2 * k for k, f in enumerate(FINGERS)}
    finger_z = {f: 4 + 2 * k for k, f in enumerate(FINGERS)}
    return Scene(model, data, tips, dict(materials or {}),
                 {"fingers": fingers, "finger_z": finger_z, "travel_mm": TRAVEL * 1e3,
                  "arm_z": arm_z, **(info or {})})


def hand4(world: str, extra: str = "", timestep: float = 0.002, arm_z: float = ARM_HOME_Z,
          materials: dict | None = None, info: dict | None = None) -> Scene:
    """The hand with a fingertip on each finger (named as the fingers), compiled with the
    objects of ``world``."""
    spec, tips = hand4_spec(world, extra, timestep, arm_z)
    return compiled(spec, tips, materials, info, arm_z)
