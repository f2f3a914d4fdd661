"""Holding with the slip reflex on MuJoCo: ``tasks/hold.py`` unchanged on a gripper whose
fingertips lie sideways, so that the object's weight pulls across their prisms.

The scene is the gripper's gantry and fingers (``gripper.gripper_xml``) with each fingertip
turned so that its prism is horizontal: its calibrated face (opposite the nail) presses the
object, the normal force along the fingertip's +x and the object's weight, carried by
friction, along its +y; both lie in the plane the force model measures. The object is a bar
standing on the table, 4 mm wide along the prisms, so that it touches the band the model is
calibrated on (0.5-4.5 mm below the nail tip); its mass and friction are the virtual world's
held objects' (``physics/grasp.py``: a plastic cup, a wooden block, a glass jar, a rubber
ball, a cardboard box), its friction deciding the contact's (``priority``).

A trial (seed ``s``), as today's world draws its own (``sim/world/slip.py``): the object in
turn, an initial grip of 1.15-1.6 x the least that holds it, set by placing each finger's
servo past the object's face, a lift of 15 mm, then :func:`~fingertip.tasks.hold.hold` for
1 s while a load of 0.2-0.8 x its mass is hung on it (an external force rising in 5 ms) at
0.3 s. The truth: how far the object slid down the fingertips.
"""
from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from ._require import mujoco
from .attach import attach_fingertip, geometry
from .gripper import ARM_HOME_Z, FINGER_KP, FINGER_OPEN_Y, LINK_LENGTH, gripper_xml
from .project import HELD_OBJECTS, HoldConfig, hold
from .robot import HAND_UNIT, MujocoArm, MujocoHand, MujocoWorld
from .scenes import Scene
from .sensor import REFLEX_AUDIO

BAR_HALF = (0.002, 0.015, 0.03)
"""Half sizes of the held bar (m): 4 mm along the prisms, 30 mm between the pads, 60 mm
tall."""
HOLD_KP = 1500.0
"""The fingers' servo stiffness (N/m) here: 1.5 N per mm past the object's face, a gripper
made to hold (the pinch gripper's 0.3 N/mm raises a grip five times slower; a sudden load
drops the object before it catches: see docs/mujoco.md)."""
LOAD_AT_S = 0.3
LOAD_RISE_S = 0.005
HOLD_S = 1.0
LIFT_MM = 15.0
DROPPED_MM = 5.0
"""Slid farther than this down the fingertips: the hold failed."""


def _sideways(side: int) -> tuple[float, float, float, float]:
    """Fingertip +x along the object's push on it (outwards, +y for the left finger), +y
    down (the weight's pull on it through friction), +z = x cross y (horizontal)."""
    x = np.array([0.0, float(side), 0.0])
    y = np.array([0.0, 0.0, -1.0])
    mat = np.column_stack([x, y, np.cross(x, y)])
    q = np.zeros(4)
    mujoco().mju_mat2Quat(q, mat.reshape(-1))
    return tuple(float(v) for v in q)


def hold_scene(mass_kg: float, friction: float, timestep: float = 0.002) -> Scene:
    """The sideways gripper around a bar of this mass and friction (``info["bar"]``)."""
    mj = mujoco()
    g = geometry()
    hx, hy, hz = BAR_HALF
    # The fingertips' calibrated band (1-4 mm below the nail tip, along the prism) over the
    # bar's 4 mm: the tip's origin sits that far from the bar's centre along the prism.
    along = g.nail_tip_z - 0.0025
    bar = (f'<body name="bar" pos="0 0 {hz}"><freejoint/>'
           f'<geom name="bar" type="box" size="{hx} {hy} {hz}" mass="{mass_kg}" '
           f'friction="{friction} 0.005 0.0001" priority="1" rgba="0.7 0.6 0.4 1"/></body>')
    xml = gripper_xml((), timestep).replace("<worldbody>", "<worldbody>" + bar, 1) \
        .replace(f'kp="{FINGER_KP}"', f'kp="{HOLD_KP}"')
    spec = mj.MjSpec.from_string(xml)
    tips = {}
    for name, side, x0 in (("left", 1, along), ("right", -1, -along)):
        tips[name] = attach_fingertip(spec, name, f"{name}_tip",
                                      pos=(x0, 0.0, -LINK_LENGTH), quat=_sideways(side))
        spec.body(f"{name}_tip").gravcomp = 1.0
    model = spec.compile()
    data = mj.MjData(model)
    bar_id = mj.mj_name2id(model, mj.mjtObj.mjOBJ_BODY, "bar")
    return Scene(model, data, tips, {}, {"bar": bar_id})


def face_gap_mm() -> float:
    """Closing travel from open to touching the bar (mm)."""
    return (FINGER_OPEN_Y - geometry().half_width - BAR_HALF[1]) * 1e3


def hold_trial(seed: int, reflex: str = "fused",
               audio: Mapping[str, float] = REFLEX_AUDIO) -> dict:
    """One trial (see the module text); what the recipe did and the truth. ``audio``: the
    piezo's block and lag (``FingertipSensor``); ``{}`` gives the sensor's defaults, which
    deliver the sound up to 113 ms late."""
    names = list(HELD_OBJECTS)
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x5A1]))
    obj = HELD_OBJECTS[names[seed % len(names)]]
    margin = math.exp(rng.uniform(math.log(1.15), math.log(1.6)))
    grip = margin * obj.mass_kg * 9.81 / (2 * obj.friction)
    added = float(rng.uniform(0.2, 0.8)) * obj.mass_kg
    scene = hold_scene(obj.mass_kg, obj.friction)
    d = scene.data
    seeds = {"left": HAND_UNIT, "right": HAND_UNIT + 1}
    world = MujocoWorld(scene, seeds, fidelity="full" if reflex == "fused" else "strain",
                        **audio)
    hand = MujocoHand(world, seeds)             # tares open
    arm = MujocoArm(world)
    down = (BAR_HALF[2] - (ARM_HOME_Z - LINK_LENGTH)) * 1e3   # the pads at the bar's middle
    arm.move_to(0.0, 0.0, down)
    squeeze = face_gap_mm() + grip / HOLD_KP * 1e3
    hand.step({"left": squeeze, "right": squeeze})
    for _ in range(40):                          # 0.5 s: close and settle
        hand.read()
    arm.slide_z(LIFT_MM, 20.0)
    while arm.moving():
        hand.read()
    for _ in range(16):
        hand.read()
    bar = scene.info["bar"]
    z0 = float(d.xpos[bar][2]) - float(arm.position()[2]) * 1e-3
    t_load = d.time + LOAD_AT_S
    end = d.time + HOLD_S
    weight = added * 9.81

    def load(data) -> None:
        u = min(1.0, max(0.0, (data.time - t_load) / LOAD_RISE_S))
        data.xfrc_applied[bar, 2] = -weight * u

    world.updates.append(load)
    track: list[tuple[float, float]] = []
    world.updates.append(lambda data: track.append(
        (data.time, (float(data.xpos[bar][2]) - float(data.qpos[world._arm_z])))))
    cfg = HoldConfig(normal_deg={"left": 0.0, "right": 0.0}, reflex=reflex,
                     stiffness_n_per_mm=HOLD_KP * 1e-3, max_step_mm=1.0,
                     finger_speed_mm_s=80.0)
    res = hold(hand, cfg, lambda: d.time < end)
    slid = (z0 - (float(d.xpos[bar][2]) - float(arm.position()[2]) * 1e-3)) * 1e3
    after = [e for e in res.slip_events if e.time >= t_load - 1e-9]
    return {"seed": seed, "object": obj.name, "reflex": reflex, "ok": res.ok,
            "held": res.ok and slid < DROPPED_MM, "slid_mm": round(slid, 2),
            "grip_n": round(grip, 3), "added_kg": round(added, 4),
            "slip_events": len(after), "false_before_load": len(res.slip_events) - len(after),
            "mean_grip_n": round(res.mean_grip_n, 3),
            "slid_before_load_mm": round((z0 - _at(track, t_load)) * 1e3, 2)}


def _at(track: list[tuple[float, float]], t: float) -> float:
    return next((z for ti, z in track if ti >= t), track[-1][1])


def run_holds(trials: int = 20, seed: int = 0) -> dict[str, list[dict]]:
    """``trials`` holds, each without a reflex and with the fused one (same seeds)."""
    return {reflex: [hold_trial(s, reflex) for s in range(seed, seed + trials)]
            for reflex in ("none", "fused")}
