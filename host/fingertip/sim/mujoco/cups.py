"""Five nested paper cups with rolled rims under the four-finger hand (MJCF written here).

Each cup is one rigid body (4 g): a rolled rim (a ring of capsules, 1.2 mm lip radius), a
wall tapered by 9 degrees (a ring of thin slanted boxes), a bottom disc, and small seat pads
out of its wall that rest on the lip of the cup below, ``pitch`` under its own rim. From the
outside the wall below each lip is inside the next lip: a nail pressed lightly on the stack
meets each rim with its lower edge, rides over the lip and leaves it into air until the next.
(The seat is level: a wall wedged on the lip below at 9 degrees creeps out of it in MuJoCo's
soft contact, climbing 0.3 mm/s.)

The nested fit clings: neighbouring cups are welded in their settled pose and a weld lets go
for good when the force it carries, or the pull its moment puts on one side of the ring
(moment / rim radius), exceeds that fit's cling (drawn per trial, 1.5-4 cup weights, as in
today's world). Rocking walks a friction fit loose: each rock pulling harder than half the
cling halves it (today's world halves it per separation stroke; here the physics says when
the fit is rocked). A rigid cup does not shear under two fingers moving in opposite
directions as a paper one does; this rule stands for that.

Contacts (``contype``/``conaffinity``): lips touch seat pads and fingertips, walls touch
fingertips only, discs touch the table.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ._require import mujoco
from .hand4 import compiled, hand4_spec
from .project import CUP_WALL
from .scenes import Scene

N_CUPS = 5
SEGMENTS = 8
"""Polygon sides of a rim and a wall (the fingers face segments' centres: 0, 90, ... deg)."""
RIM_RADIUS = 0.035
LIP_RADIUS = 0.0012
WALL_TOP_INSET = 0.0002
"""The wall's outer face just below the lip, inside the lip's centre line (m)."""
WALL_HEIGHT = 0.08
WALL_THICK = 0.0004
CUP_MASS = 0.004
DISC_HALF = 0.0005
TAPER = 0.16
"""The wall's radius lost per metre of height (9 degrees): below its lip a wall is inside the
lower cup's lip by then, for pitches of 6.5 mm and more."""
PAD_HALF = (0.002, 0.0005)
"""Tangential and vertical half sizes of a seat pad (m)."""


def lip_outer() -> float:
    """The rims' outermost radius (m)."""
    return RIM_RADIUS + LIP_RADIUS


def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    out = np.zeros(4)
    mujoco().mju_mulQuat(out, a, b)
    return out


def _cup(k: int, z_rim: float, pitch: float) -> str:
    """Cup ``k`` (0: the top) with its rim at height ``z_rim`` (m)."""
    t = TAPER
    n, half = SEGMENTS, math.pi / SEGMENTS
    r0 = RIM_RADIUS - WALL_TOP_INSET
    slant = WALL_HEIGHT * math.sqrt(1 + t * t)
    r_mid = r0 - WALL_HEIGHT / 2 * t
    tilt = math.atan(t)
    masses = {"lip": 0.3 * CUP_MASS / n, "wall": 0.6 * CUP_MASS / n, "disc": 0.1 * CUP_MASS}
    geoms = []
    for i in range(n):
        phi = 2 * math.pi * i / n
        c, s = math.cos(phi), math.sin(phi)
        ln = RIM_RADIUS * math.tan(half)
        a = (RIM_RADIUS * c + ln * s, RIM_RADIUS * s - ln * c, 0.0)
        b = (RIM_RADIUS * c - ln * s, RIM_RADIUS * s + ln * c, 0.0)
        geoms.append(f'<geom name="cup{k}_lip{i}" type="capsule" size="{LIP_RADIUS}" '
                     f'fromto="{a[0]:.6f} {a[1]:.6f} 0 {b[0]:.6f} {b[1]:.6f} 0" '
                     f'mass="{masses["lip"]:.7f}" contype="2" conaffinity="5" condim="3" '
                     f'friction="0.35 0.005 0.0001" solref="0.004 1" '
                     f'rgba="0.95 0.95 0.92 1"/>')
        q = _quat_mul(np.array([math.cos(phi / 2), 0, 0, math.sin(phi / 2)]),
                      np.array([math.cos(tilt / 2), 0, math.sin(tilt / 2), 0]))
        rc = r_mid - WALL_THICK / 2
        geoms.append(f'<geom name="cup{k}_wall{i}" type="box" size="{WALL_THICK / 2} '
                     f'{r0 * math.tan(half):.6f} {slant / 2:.6f}" '
                     f'pos="{rc * c:.6f} {rc * s:.6f} {-WALL_HEIGHT / 2:.6f}" '
                     f'quat="{q[0]:.6f} {q[1]:.6f} {q[2]:.6f} {q[3]:.6f}" '
                     f'mass="{masses["wall"]:.7f}" contype="0" conaffinity="1" condim="3" '
                     f'friction="0.35 0.005 0.0001" '
                     f'rgba="0.97 0.97 0.95 1"/>')
        # The seat: a pad out of the wall resting on the lower cup's lip (a level contact:
        # a wall wedged on a lip at 9 degrees creeps out of it in MuJoCo's soft contact).
        z_pad = -pitch + LIP_RADIUS + PAD_HALF[1]
        r_in = r0 + z_pad * t
        pr = (RIM_RADIUS - r_in) / 2
        rp = r_in + pr
        geoms.append(f'<geom name="cup{k}_pad{i}" type="box" size="{pr:.6f} {PAD_HALF[0]} '
                     f'{PAD_HALF[1]}" pos="{rp * c:.6f} {rp * s:.6f} {z_pad:.6f}" '
                     f'quat="{math.cos(phi / 2):.6f} 0 0 {math.sin(phi / 2):.6f}" mass="0" '
                     f'contype="4" conaffinity="0" condim="3" friction="0.35 0.005 0.0001" '
                     f'solref="0.004 1" rgba="0.97 0.97 0.95 1"/>')
    r_bottom = r0 - WALL_HEIGHT * t - 0.001
    geoms.append(f'<geom name="cup{k}_disc" type="cylinder" size="{r_bottom:.6f} {DISC_HALF}" '
                 f'pos="0 0 {-WALL_HEIGHT:.6f}" mass="{masses["disc"]:.7f}" contype="8" '
                 f'conaffinity="1" solref="0.004 1" rgba="0.9 0.9 0.88 1"/>')
    body = "\n        ".join(geoms)
    return f'''
    <body name="cup{k}" pos="0 0 {z_rim:.6f}">
      <freejoint/>
        {body}
    </body>'''


def rim_heights(pitch_m: float) -> np.ndarray:
    """Each cup's rim centre above the table (m), top cup first."""
    bottom = WALL_HEIGHT + DISC_HALF
    return bottom + pitch_m * np.arange(N_CUPS - 1, -1, -1)


ROCK_FRACTION = 0.5
LOOSEN = 0.5
"""A rock of the fit (see :class:`FitBreaker`) halves its cling, as today's world's stroke."""


@dataclass
class FitBreaker:
    """The nested fits' welds, each let go when the force it carries (or the pull a moment
    puts on one side of the ring, moment / rim radius) exceeds its cling. A friction fit
    rocked back and forth walks loose: each rock pulling harder than ``ROCK_FRACTION`` of
    the cling halves it (``rocks`` counts them)."""

    eq_ids: list[int]
    cling_n: list[float]
    broken: list[bool] = field(default_factory=list)
    peak_n: list[float] = field(default_factory=list)
    """Per fit, the largest load it carried (force or moment / rim radius), in N."""

    def __post_init__(self) -> None:
        self.cling_n = list(self.cling_n)
        self.rocks = [0] * len(self.eq_ids)
        self._rocking = [False] * len(self.eq_ids)
        self.broken = [False] * len(self.eq_ids)
        self.peak_n = [0.0] * len(self.eq_ids)
        self._eq = int(mujoco().mjtConstraint.mjCNSTR_EQUALITY)

    def update(self, data) -> None:
        n = data.nefc
        rows = np.flatnonzero(data.efc_type[:n] == self._eq)
        if not rows.size:
            return
        ids = data.efc_id[rows]
        for j, eq in enumerate(self.eq_ids):
            if self.broken[j]:
                continue
            mine = rows[ids == eq]
            if not mine.size:
                continue
            # A weld's rows: its force (3), then its moment (3). A moment M rocks the fit:
            # it pulls one side of the ring apart with about M / R.
            f = float(np.sqrt(np.sum(data.efc_force[mine[:3]] ** 2)))
            m = float(np.sqrt(np.sum(data.efc_force[mine[3:6]] ** 2)))
            rock = m / RIM_RADIUS
            # A rock pulling one side harder than half the cling slips the fit a little and
            # loosens it: once per rock (the moment rises above, then falls below, half that).
            if rock > ROCK_FRACTION * self.cling_n[j] and not self._rocking[j]:
                self.cling_n[j] *= LOOSEN
                self.rocks[j] += 1
                self._rocking[j] = True
            elif rock < 0.5 * ROCK_FRACTION * self.cling_n[j]:
                self._rocking[j] = False
            f = max(f, rock)
            self.peak_n[j] = max(self.peak_n[j], f)
            if f > self.cling_n[j]:
                data.eq_active[eq] = 0
                self.broken[j] = True


def cup_stack(pitch_m: float = 0.007, cling_n: list[float] | None = None,
              timestep: float = 0.002, arm_z: float = 0.2) -> Scene:
    """The hand over a stack of five cups at the origin (rims ``pitch_m`` apart).

    ``scene.info``: ``rims_m`` (each rim's centre height, top first), ``cups`` (body ids),
    ``fits`` (the :class:`FitBreaker`, run after every step by the hand's world)."""
    cling = list(cling_n) if cling_n is not None else [2.5 * CUP_MASS * 9.81] * (N_CUPS - 1)
    if len(cling) != N_CUPS - 1:
        raise ValueError(f"one cling per fit: {N_CUPS - 1} values, not {len(cling)}")
    rims = rim_heights(pitch_m)
    world = "".join(_cup(k, float(z), pitch_m) for k, z in enumerate(rims))
    welds = "".join(f'<weld name="fit{k}" body1="cup{k}" body2="cup{k + 1}" '
                    f'solref="0.01 1"/>' for k in range(N_CUPS - 1))
    materials = {f"cup{k}_{part}{i}": CUP_WALL for k in range(N_CUPS)
                 for part in ("lip", "wall") for i in range(SEGMENTS)}
    spec, tips = hand4_spec(world, f"<equality>{welds}</equality>", timestep, arm_z)
    _settle(spec, tips, 0.3)
    scene = compiled(spec, tips, materials, arm_z=arm_z)
    mj = mujoco()
    m = scene.model
    fits = FitBreaker([mj.mj_name2id(m, mj.mjtObj.mjOBJ_EQUALITY, f"fit{k}")
                       for k in range(N_CUPS - 1)], cling)
    scene.info.update({"rims_m": rims, "pitch_m": pitch_m, "fits": fits,
                       "updates": [fits.update],
                       "cups": [mj.mj_name2id(m, mj.mjtObj.mjOBJ_BODY, f"cup{k}")
                                for k in range(N_CUPS)]})
    return scene


def _settle(spec, tips: dict, seconds: float = 1.0) -> None:
    """Let the stack settle into its seats without the fits, then place the cups there in
    ``spec`` (the welds then hold the settled pose, carrying no load at rest)."""
    mj = mujoco()
    scene = compiled(spec, tips)
    m, d = scene.model, scene.data
    d.eq_active[:] = 0
    d.ctrl[2] = 0.0
    while d.time < seconds:
        mj.mj_step(m, d)
    for k in range(N_CUPS):
        b = spec.body(f"cup{k}")
        i = mj.mj_name2id(m, mj.mjtObj.mjOBJ_BODY, f"cup{k}")
        b.pos = d.xpos[i].copy()
        b.quat = d.xquat[i].copy()
