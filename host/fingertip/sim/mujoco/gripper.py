"""A parallel-jaw gripper on a Cartesian arm, a fingertip on each finger, and objects that
break above a force (MJCF written here).

The arm is a gantry: three slide joints with position servos (x, y, z), gravity compensated,
as position-controlled joints of a real arm are. The palm carries two fingers on slide joints
that close towards each other (position servos), each finger a link with a fingertip at its
end: the fingertip points down (its +z to -z of the world), its -x face (channel 2's) towards
the object, the nail outwards. Controls (``data.ctrl``): 0-2 the arm's offsets from its home
(m), 3 and 4 the left and right fingers' closing travel (m, 0 = open).

Objects (the virtual world's specs, ``sim/world/hand.py``: tofu 12 g breaking at 1.5 N, a
potato chip 2 g at 0.4 N): each is two halves held by a weld; :class:`Breakables` releases the
weld when the contact force on the object exceeds the crush force, and the halves fall apart.
The chip stands upright in a slotted holder, as a chip is offered to a gripper.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ._require import mujoco
from .attach import attach_fingertip
from .project import CHIP, TOFU
from .scenes import Scene, header

FINGER_OPEN_Y = 0.045
"""Each fingertip's axis from the palm's centre when open (m)."""
LINK_LENGTH = 0.06
ARM_HOME_Z = 0.2
FINGER_KP = 300.0
"""Finger servo stiffness (N/m): 1 mm past the contact squeezes with 0.3 N."""

# Left finger: fingertip +x -> +y (outwards), +z -> -z; right finger mirrored.
LEFT_QUAT = (0.0, 0.7071067811865476, 0.7071067811865476, 0.0)
RIGHT_QUAT = (0.0, -0.7071067811865476, 0.7071067811865476, 0.0)


@dataclass
class Breakables:
    """Welds that break when the contact force on their object exceeds its crush force."""

    eq_ids: dict[str, int] = field(default_factory=dict)
    crush_n: dict[str, float] = field(default_factory=dict)
    sensors: dict[str, list[tuple[slice, slice]]] = field(default_factory=dict)
    """Per object, per fingertip: the net force slices of its contacts with the two halves."""
    broken: dict[str, bool] = field(default_factory=dict)

    def update(self, data) -> None:
        """Break what a fingertip squeezes harder than its crush force (after each step)."""
        sd = data.sensordata
        for name, eq in self.eq_ids.items():
            if self.broken[name]:
                continue
            for a, b in self.sensors[name]:
                force = sd[a] + sd[b]
                if float(np.sqrt(force @ force)) > self.crush_n[name]:
                    data.eq_active[eq] = 0
                    self.broken[name] = True
                    break


def _halves(name: str, pos: tuple[float, float, float], half: tuple[float, float, float],
            mass: float, rgba: str, solref: str) -> str:
    hx, hy, hz = half
    out = []
    for side, dx in (("a", -hx / 2), ("b", hx / 2)):
        out.append(f'''
    <body name="{name}_{side}" pos="{pos[0] + dx} {pos[1]} {pos[2]}">
      <freejoint/>
      <geom name="{name}_{side}" type="box" size="{hx / 2} {hy} {hz}" mass="{mass / 2}"
            rgba="{rgba}" solref="{solref}" friction="0.6 0.005 0.0001"/>
    </body>''')
    return "".join(out)


def gripper_xml(objects: tuple[str, ...] = ("tofu",), timestep: float = 0.002) -> str:
    """The scene's MJCF without its fingertips (see :func:`gripper`)."""
    bodies, welds, excludes = [], [], []
    for i, name in enumerate(objects):
        x = 0.12 * i
        if name == "tofu":
            half = (0.015, 0.015, 0.0125)
            bodies.append(_halves("tofu", (x, 0, half[2]), half, TOFU.mass_kg,
                                  "0.95 0.93 0.8 1", "0.03 1"))
        elif name == "chip":
            half = (0.018, 0.001, 0.015)
            z = 0.004 + half[2]
            bodies.append(_halves("chip", (x, 0, z), half, CHIP.mass_kg, "0.9 0.75 0.3 1",
                                  "0.005 1"))
            for sx in (-1, 1):  # the holder's slot at each end of the chip
                for sy in (-1, 1):
                    bodies.append(f'<geom name="holder_{sx}_{sy}" type="box" '
                                  f'size="0.003 0.001 0.006" pos="{x + sx * 0.021} '
                                  f'{sy * 0.0022} 0.006" rgba="0.4 0.4 0.4 1"/>')
        else:
            raise ValueError(f"unknown object {name!r}: one of tofu, chip")
        welds.append(f'<weld name="{name}_weld" body1="{name}_a" body2="{name}_b"/>')
        excludes.append(f'<exclude body1="{name}_a" body2="{name}_b"/>')
    z0 = ARM_HOME_Z
    return header("fingertip_gripper", timestep, "table") + f"""
    {"".join(bodies)}
    <body name="arm" pos="0 0 {z0}" gravcomp="1">
      <joint name="arm_x" type="slide" axis="1 0 0" damping="20"/>
      <joint name="arm_y" type="slide" axis="0 1 0" damping="20"/>
      <joint name="arm_z" type="slide" axis="0 0 1" damping="20"/>
      <geom name="palm" type="box" size="0.02 0.06 0.01" mass="0.5" rgba="0.3 0.3 0.35 1"/>
      <body name="left" pos="0 {FINGER_OPEN_Y} 0" gravcomp="1">
        <joint name="left" type="slide" axis="0 -1 0" range="0 0.04" damping="2"/>
        <geom name="left_link" type="box" size="0.008 0.006 {LINK_LENGTH / 2}"
              pos="0 0.004 {-LINK_LENGTH / 2}" mass="0.05" rgba="0.5 0.5 0.55 1"/>
      </body>
      <body name="right" pos="0 {-FINGER_OPEN_Y} 0" gravcomp="1">
        <joint name="right" type="slide" axis="0 1 0" range="0 0.04" damping="2"/>
        <geom name="right_link" type="box" size="0.008 0.006 {LINK_LENGTH / 2}"
              pos="0 -0.004 {-LINK_LENGTH / 2}" mass="0.05" rgba="0.5 0.5 0.55 1"/>
      </body>
    </body>
  </worldbody>
  <contact>{"".join(excludes)}</contact>
  <equality>{"".join(welds)}</equality>
  <actuator>
    <position name="arm_x" joint="arm_x" kp="4000" kv="200" ctrlrange="-1 1"/>
    <position name="arm_y" joint="arm_y" kp="4000" kv="200" ctrlrange="-1 1"/>
    <position name="arm_z" joint="arm_z" kp="4000" kv="200" ctrlrange="-1 1"/>
    <position name="left" joint="left" kp="{FINGER_KP}" kv="8" ctrlrange="0 0.04"/>
    <position name="right" joint="right" kp="{FINGER_KP}" kv="8" ctrlrange="0 0.04"/>
  </actuator>
</mujoco>"""


def gripper(objects: tuple[str, ...] = ("tofu",), timestep: float = 0.002) -> Scene:
    """The gripper scene compiled with its two fingertips (``left``, ``right``).

    ``scene.info["breakables"]`` breaks the objects: call its ``update(data)`` each step.
    """
    mj = mujoco()
    spec = mj.MjSpec.from_string(gripper_xml(objects, timestep))
    tips = {}
    for side, quat in (("left", LEFT_QUAT), ("right", RIGHT_QUAT)):
        tips[side] = attach_fingertip(spec, side, f"{side}_tip",
                                      pos=(0.0, 0.0, -LINK_LENGTH), quat=quat)
        spec.body(f"{side}_tip").gravcomp = 1.0
    for name in objects:
        for side in tips:
            for half in "ab":
                s = spec.add_sensor(name=f"{name}_{half}_{side}", type=mj.mjtSensor.mjSENS_CONTACT,
                                    objtype=mj.mjtObj.mjOBJ_BODY, objname=f"{side}_tip",
                                    reftype=mj.mjtObj.mjOBJ_BODY, refname=f"{name}_{half}")
                s.intprm[:3] = [2, 3, 1]  # the force, summed over the pair's contacts
    model = spec.compile()
    data = mj.MjData(model)
    brk = Breakables()
    for name in objects:
        brk.eq_ids[name] = mj.mj_name2id(model, mj.mjtObj.mjOBJ_EQUALITY, f"{name}_weld")
        brk.sensors[name] = []
        for side in tips:
            pair = []
            for half in "ab":
                sid = mj.mj_name2id(model, mj.mjtObj.mjOBJ_SENSOR, f"{name}_{half}_{side}")
                adr = int(model.sensor_adr[sid])
                pair.append(slice(adr, adr + 3))
            brk.sensors[name].append((pair[0], pair[1]))
        brk.crush_n[name] = {"tofu": TOFU.crush_n, "chip": CHIP.crush_n}[name]
        brk.broken[name] = False
    return Scene(model, data, tips, {}, {"breakables": brk, "objects": objects})
