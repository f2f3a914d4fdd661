"""Scenes in MJCF written here (no downloaded assets), each with its fingertips attached.

- :func:`probe`: one fingertip, cap down, on a three-axis position-controlled probe (slide
  joints with position servos, gravity compensated) over plates of the paper's seven
  materials. Pressing is a position target below the surface: the servo's stiffness
  turns the overshoot into a force (``kp`` N/m), as a real probe's compliance does.

MuJoCo's friction acts on velocities: a mocap body that is teleported has none and drags
nothing, so every moving part here is a jointed body driven by actuators.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._require import mujoco
from .attach import AttachedFingertip, attach_fingertip, geometry
from .project import PAPER_SEVEN, material_named

PLATE_HALF = (0.04, 0.06, 0.004)
"""Half sizes of one material plate (m): 8 x 12 cm, 8 mm thick."""
PLATE_PITCH = 0.09
LATERAL_KP = 20000.0
"""The probe's horizontal servos (N/m): stiff, as a Cartesian robot's axes are; a soft one
(2000 N/m) stick-slips against the nail's friction."""
CAP_DOWN = (0.0, 1.0, 0.0, 0.0)
"""The fingertip's +z down, its nail towards +x."""
NAIL_DOWN = (math.cos(math.pi / 4), 0.0, math.sin(math.pi / 4), 0.0)
"""The fingertip's +x (the nail) down, its +z along +x."""
SIDE_DOWN = (math.cos(-math.pi / 4), 0.0, math.sin(-math.pi / 4), 0.0)
"""The face opposite the nail (channel 2's) down, the fingertip's +z along -x: the side
the force model is calibrated on (forces at 0 +- 50 degrees in its frame)."""
EDGE_DOWN = (math.cos(3 * math.pi / 8), 0.0, math.sin(3 * math.pi / 8), 0.0)
"""Half-way: the edge between the cap's roof and its nail side down."""


@dataclass
class Scene:
    """A compiled scene: model, data, and its fingertips by name."""

    model: object
    data: object
    tips: dict[str, AttachedFingertip]
    materials: dict[str, str]
    """Geom name -> material name (for :class:`~.sensor.FingertipSensor`)."""
    info: dict


def plate_geom(name: str) -> str:
    return f"plate_{name}"


def _plates_xml(materials: tuple[str, ...], rail_half_x: float | None = None) -> str:
    hx, hy, hz = PLATE_HALF
    hx = rail_half_x or hx
    out = []
    for i, name in enumerate(materials):
        mat = material_named(name)
        shade = 0.3 + 0.6 * i / max(1, len(materials) - 1)
        out.append(f'<geom name="{plate_geom(name)}" type="box" size="{hx} {hy} {hz}" '
                   f'pos="{i * PLATE_PITCH} 0 {hz}" friction="{mat.friction} 0.005 0.0001" '
                   f'rgba="{shade} 0.5 {1 - shade} 1"/>')
    return "\n".join(out)


def header(model: str, timestep: float, ground: str) -> str:
    """The opening of a scene's MJCF: options (elliptic cones: clean friction forces), a
    light and the ground plane named ``ground``."""
    return f"""
<mujoco model="{model}">
  <option timestep="{timestep}" cone="elliptic" impratio="10"/>
  <worldbody>
    <light pos="0 0 1" dir="0 0 -1"/>
    <geom name="{ground}" type="plane" size="1 1 0.05" rgba="0.75 0.75 0.77 1"/>"""


def lowest_z(quat: tuple[float, float, float, float]) -> float:
    """The lowest point of a fingertip turned by ``quat`` (w, x, y, z), relative to its
    frame's origin (m): the corners of its skin and nail boxes."""
    mj = mujoco()
    g = geometry()
    h = g.half_width
    corners = [(x, y, z) for x in (-h, h) for y in (-h, h) for z in (g.skirt_z, g.top_z)]
    corners += [(x, y, z) for x in g.nail_x for y in (-g.nail_half_y, g.nail_half_y)
                for z in g.nail_z]
    out = np.zeros(3)
    low = 0.0
    for c in corners:
        mj.mju_rotVecQuat(out, np.asarray(c, float), np.asarray(quat, float))
        low = min(low, float(out[2]))
    return low


def probe_xml(materials: tuple[str, ...] = PAPER_SEVEN, timestep: float = 0.002,
              kp: float = 500.0, quat: tuple[float, float, float, float] = CAP_DOWN,
              rail_half_x: float | None = None) -> str:
    """The probe scene's MJCF (the fingertip is attached by :func:`probe`)."""
    top = 2 * PLATE_HALF[2]
    start = top - lowest_z(quat) + 0.01
    kv = 2 * (kp * 0.2) ** 0.5  # critically damped for the probe's 0.2 kg
    kv_xy = 2 * (LATERAL_KP * 0.2) ** 0.5
    return header("fingertip_probe", timestep, "floor") + f"""
    {_plates_xml(materials, rail_half_x)}
    <body name="probe" pos="0 0 {start:.4f}" gravcomp="1">
      <joint name="px" type="slide" axis="1 0 0" damping="2"/>
      <joint name="py" type="slide" axis="0 1 0" damping="2"/>
      <joint name="pz" type="slide" axis="0 0 1" damping="2"/>
      <geom name="probe_body" type="cylinder" size="0.012 0.01" pos="0 0 0.01" mass="0.2"
            contype="0" conaffinity="0" rgba="0.3 0.3 0.35 1"/>
    </body>
  </worldbody>
  <actuator>
    <position name="ax" joint="px" kp="{LATERAL_KP}" kv="{kv_xy}" ctrlrange="-1 1"/>
    <position name="ay" joint="py" kp="{LATERAL_KP}" kv="{kv_xy}" ctrlrange="-1 1"/>
    <position name="az" joint="pz" kp="{kp}" kv="{kv}" ctrlrange="-1 1"/>
  </actuator>
</mujoco>"""


def probe(materials: tuple[str, ...] = PAPER_SEVEN, timestep: float = 0.002,
          kp: float = 500.0, quat: tuple[float, float, float, float] = CAP_DOWN,
          rail_half_x: float | None = None) -> Scene:
    """One fingertip on the probe, turned by ``quat`` (default: cap down, nail towards +x;
    :data:`NAIL_DOWN` presents the nail; :data:`EDGE_DOWN` the cap's edge above the nail;
    :data:`SIDE_DOWN` the face opposite the nail). ``rail_half_x``: each plate is a rail
    this narrow (half width, m) along y, so that only a band of a flat face touches it.

    Controls: ``data.ctrl[0:3]`` = probe offsets (m) from its start in x, y, z. The skin's
    lowest point starts 10 mm above the plates; plate ``i`` is centred at x = i * 9 cm.
    """
    mj = mujoco()
    spec = mj.MjSpec.from_string(probe_xml(materials, timestep, kp, quat, rail_half_x))
    tip = attach_fingertip(spec, "probe", "tip", quat=quat)
    spec.body("tip").gravcomp = 1.0  # the probe's servo carries the fingertip's weight too
    model = spec.compile()
    data = mj.MjData(model)
    return Scene(model, data, {"tip": tip}, {plate_geom(m): m for m in materials},
                 {"gap_m": 0.01, "plate_pitch_m": PLATE_PITCH, "kp": kp})
