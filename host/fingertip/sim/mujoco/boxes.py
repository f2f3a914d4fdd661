"""Two closed boxes with loose contents under the four-finger hand (MJCF written here).

Each box is a matchbox: a sleeve (a free body: the two sides the nails of ``f0`` and ``f2``
press on, a roof and a floor, open at both ends) and a tray inside it on a slide joint along
y (its floor and its two end plates; the sliding friction of cardboard on cardboard is the
joint's ``frictionloss``, 0.3 N as in today's world). The finger ``f1`` pushes the tray's +y
end plate: the tray slides out of the sleeve's -y end. A body and its child do not collide in
MuJoCo, so tray and sleeve slide on the joint alone.

The contents are free bodies inside (screws: steel capsules of 2 g; rubber bands: soft, light,
grippy discs of 1 g), closed in by the sleeve's sides and roof and the tray's end plates and
floor. Shaking the held box makes them slide and hit the walls because of their mass and
friction and the box's motion: nothing here is scripted. :mod:`.box_sound` turns their
contacts with the walls into what the gripping fingertip's piezo hears.

Box mass as today's world: 0.1 kg plus 5 g per item (the items' own masses included).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._require import mujoco
from .hand4 import compiled, hand4_spec
from .project import ITEM_MASS_KG as ITEM_MASS
from .scenes import Scene

CONTENTS = ("screws", "rubber_bands")
HALF = (0.03, 0.03, 0.022)
"""The sleeve's outer half sizes (m): x between the gripped sides, y along the tray, z. Square,
so that the tray pushed out towards -y by ``f1`` has 14 mm before the open finger ``f3``."""
WALL = 0.002
"""Cardboard thickness (m)."""
BOX_X = (-0.08, 0.08)
"""The boxes' centres on the table (m), as today's world's (-80, +80) mm."""
TRAY_FRICTION_N = 0.3
TRAY_FRICTION_SOLREF = (0.004, 1.0)
TRAY_FRICTION_SOLIMP = (0.999, 0.999, 0.001)
"""MuJoCo's joint friction is a soft constraint: with its default softness (0.02 s; 0.9-0.95)
the tray crept 13 mm in 2 s under 0.1 N, a third of its friction, and a tray's end plate
nudged by a rolling screw slid out. Stiffened (the shortest stable time constant, two 2 ms
steps, and an impedance of 0.999) it creeps under 0.1 mm in 2 s at 0.29 N and slides above
0.3 N, as the dry friction it stands for (tests/sim/mujoco/test_shake.py)."""
TRAY_TRAVEL = 0.035
BOX_FRICTION = 0.8
"""Nail on cardboard (MuJoCo takes the larger of two geoms' friction)."""
ITEM_REACH = 0.0065
"""The largest item's reach from its centre in the tray's plane (m): a screw's half length
with its rounded end (5 + 1.5 mm); a rubber band's disc has 6 mm."""


@dataclass(frozen=True)
class BoxFill:
    content: str
    items: int


def _item(b: int, i: int, content: str, pos: np.ndarray, yaw: float) -> str:
    name = f"box{b}_item{i}"
    c, s = np.cos(yaw / 2), np.sin(yaw / 2)
    quat = f"{c:.6f} 0 0 {s:.6f}"
    if content == "screws":
        # An M3 x 12 screw: a steel capsule, hard contact, steel on cardboard friction.
        geom = (f'<geom name="{name}" type="capsule" size="0.0015 0.005" euler="0 90 0" '
                f'mass="{ITEM_MASS[content]}" friction="0.3 0.005 0.0001" '
                f'solref="0.002 0.5" contype="2" conaffinity="2" rgba="0.7 0.7 0.75 1"/>')
    else:
        # A bundled rubber band: a soft, grippy flat disc; its contact soft and dead.
        geom = (f'<geom name="{name}" type="cylinder" size="0.006 0.0015" '
                f'mass="{ITEM_MASS[content]}" friction="1.0 0.01 0.001" '
                f'solref="0.01 1.5" contype="2" conaffinity="2" '
                f'rgba="0.85 0.45 0.3 1"/>')
    return (f'<body name="{name}" pos="{pos[0]:.5f} {pos[1]:.5f} {pos[2]:.5f}" '
            f'quat="{quat}"><freejoint/>{geom}</body>')


def item_places(n: int, free: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """``n`` starting places (x, y) within +-``free`` (m): random cells of a grid whose
    pitch is at least twice ``ITEM_REACH``, each place jittered within its cell, so that no
    two items start overlapping. Items that overlap, or fall onto one another from stacked
    layers, are thrown apart by the contact solver fast enough to sink into the 2 mm tray
    floor, where one wedged between the tray's and the sleeve's floors drags the tray out."""
    cells = np.floor(2 * free / (2 * ITEM_REACH)).astype(int) + 1
    pitch = 2 * free / np.maximum(cells - 1, 1)
    if n > cells.prod():
        raise ValueError(f"no room for {n} items on the tray's floor (at most "
                         f"{cells.prod()})")
    pick = rng.choice(cells.prod(), size=n, replace=False)
    ij = np.stack([pick // cells[1], pick % cells[1]], axis=1)
    jitter = rng.uniform(-1, 1, (n, 2)) * (pitch / 2 - ITEM_REACH)
    return np.clip(-free + ij * pitch + jitter, -free, free)


def _box(b: int, x: float, fill: BoxFill, rng: np.random.Generator) -> str:
    hx, hy, hz = HALF
    t = WALL / 2
    items_mass = ITEM_MASS[fill.content] * fill.items
    total = 0.1 + 0.005 * fill.items
    shell = total - items_mass
    sleeve_m, tray_m = 0.8 * shell, 0.2 * shell
    card = (f'friction="{BOX_FRICTION} 0.005 0.0001" contype="3" conaffinity="3" '
            f'rgba="0.72 0.6 0.42 1"')
    sleeve = [
        f'<geom name="box{b}_side_px" type="box" size="{t} {hy} {hz}" pos="{hx - t} 0 0" '
        f'mass="{sleeve_m * 0.3:.5f}" {card}/>',
        f'<geom name="box{b}_side_nx" type="box" size="{t} {hy} {hz}" pos="{-hx + t} 0 0" '
        f'mass="{sleeve_m * 0.3:.5f}" {card}/>',
        f'<geom name="box{b}_roof" type="box" size="{hx} {hy} {t}" pos="0 0 {hz - t}" '
        f'mass="{sleeve_m * 0.2:.5f}" {card}/>',
        f'<geom name="box{b}_floor" type="box" size="{hx} {hy} {t}" pos="0 0 {-hz + t}" '
        f'mass="{sleeve_m * 0.2:.5f}" {card}/>']
    ix, iz = hx - WALL, hz - WALL
    tray = [
        f'<geom name="box{b}_tray_floor" type="box" size="{ix} {hy - WALL} {t}" '
        f'pos="0 0 {-iz + t}" mass="{tray_m * 0.5:.5f}" {card}/>',
        f'<geom name="box{b}_tray_py" type="box" size="{ix} {t} {iz}" pos="0 {hy - t} 0" '
        f'mass="{tray_m * 0.25:.5f}" {card}/>',
        f'<geom name="box{b}_tray_ny" type="box" size="{ix} {t} {iz}" pos="0 {-hy + t} 0" '
        f'mass="{tray_m * 0.25:.5f}" {card}/>']
    # The items dropped side by side onto the tray's floor (they settle before the trial).
    free = np.array([ix - 0.007, hy - WALL - 0.007])
    items = []
    for i, p in enumerate(item_places(fill.items, free, rng)):
        z = -iz + WALL + 0.002
        items.append(_item(b, i, fill.content, np.array([x + p[0], p[1], hz + z]),
                           float(rng.uniform(0, 2 * np.pi))))
    return f'''
    <body name="box{b}" pos="{x} 0 {hz}">
      <freejoint/>
      {"".join(sleeve)}
      <body name="box{b}_tray">
        <joint name="box{b}_tray" type="slide" axis="0 -1 0" range="0 {TRAY_TRAVEL}"
               frictionloss="{TRAY_FRICTION_N}" damping="0.5"
               solreffriction="{TRAY_FRICTION_SOLREF[0]} {TRAY_FRICTION_SOLREF[1]}"
               solimpfriction="{' '.join(map(str, TRAY_FRICTION_SOLIMP))}"/>
        {"".join(tray)}
      </body>
    </body>
    {"".join(items)}'''


def box_pair(fills: tuple[BoxFill, BoxFill], seed: int = 0, timestep: float = 0.002,
             arm_z: float = 0.2, settle_s: float = 0.4) -> Scene:
    """The hand over two boxes at ``BOX_X`` with these fills, the contents settled.

    ``scene.info``: ``boxes`` (per box: ``body``, ``tray_joint`` (qpos address), ``geoms``
    (the box's own geom ids), ``items`` (the contents' geom ids), ``content``)."""
    for f in fills:
        if f.content not in CONTENTS:
            raise ValueError(f"content must be one of {CONTENTS}, not {f.content!r}")
        if f.items < 0:
            raise ValueError(f"items must be >= 0, not {f.items}")
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0xB0B5]))
    world = "".join(_box(b, x, f, rng) for b, (x, f) in enumerate(zip(BOX_X, fills,
                                                                       strict=True)))
    spec, tips = hand4_spec(world, "", timestep, arm_z)
    scene = compiled(spec, tips, arm_z=arm_z)
    mj = mujoco()
    m, d = scene.model, scene.data
    boxes = []
    for b, f in enumerate(fills):
        body = mj.mj_name2id(m, mj.mjtObj.mjOBJ_BODY, f"box{b}")
        tray = mj.mj_name2id(m, mj.mjtObj.mjOBJ_BODY, f"box{b}_tray")
        geoms = [g for g in range(m.ngeom) if m.geom_bodyid[g] in (body, tray)]
        items = [mj.mj_name2id(m, mj.mjtObj.mjOBJ_GEOM, f"box{b}_item{i}")
                 for i in range(f.items)]
        joint = mj.mj_name2id(m, mj.mjtObj.mjOBJ_JOINT, f"box{b}_tray")
        boxes.append({"body": body, "tray_qpos": int(m.jnt_qposadr[joint]),
                      "geoms": geoms, "items": items, "content": f.content,
                      "n_items": f.items})
    scene.info["boxes"] = boxes
    while d.time < settle_s:                  # the contents drop onto the tray's floor
        mj.mj_step(m, d)
    return scene
