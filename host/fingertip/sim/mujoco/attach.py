"""Attach a fingertip to a body of a MuJoCo model (``MjSpec``): its collision geometry, mass,
friction and MuJoCo's own ``contact`` sensors over it.

The fingertip's frame (as in ``fingertip.toml`` [mount]): origin on the prism axis in the
base's underside plane, +z along the prism towards the cap, +x the normal of channel 0's face,
where the fingernail is. The user places that frame on a body of their model with ``pos`` (m)
and ``quat`` (w, x, y, z) relative to the body.

Collision geometry, from the same dimensions the CAD uses:

- ``base``: the TPU base, as a box of the envelope's width (the triangle's corners are inside
  it) from the underside to the prism root;
- ``skin``: the silicone over the cap, one box of the envelope's width from the cap skirt's rim
  up to the skin over the cap roof; its contact is soft over the skin's thickness
  (``solimp`` width) and has the skin's friction;
- ``nail``: the PLA fingernail on the +x face, its top edge at the nail tip, standing
  ``nail_proud_mm`` out of the skin; hard contact, PLA's friction.

Masses come from the parts' volumes and densities (ours: printed PLA 1240 kg/m^3, TPU 95A
1210, Mold Star 20T 1220). The fingertip is one rigid body welded to its parent: the prism's
deflection under 5 N is a few micrometres, far below any contact's penetration.
"""
from __future__ import annotations

from dataclasses import dataclass

from ._require import mujoco
from .project import FingertipParams, load_params, load_realism

PLA_KG_M3 = 1240.0
TPU_KG_M3 = 1210.0
SILICONE_KG_M3 = 1220.0
PLA_FRICTION = 0.35
"""PLA on most surfaces (ours: 0.3-0.4); a contact takes the larger of its two geoms'."""
SKIN_SOLREF = (0.01, 1.0)
"""Time constant (s) and damping ratio of the skin's contact (stable for steps up to 5 ms)."""
NAIL_SOLREF = (0.005, 1.0)

# MuJoCo's contact sensor: bits of the data it returns, and how it reduces several contacts.
_FOUND, _FORCE, _DIST, _POS, _NORMAL = 1, 2, 8, 16, 32
_MINDIST, _NETFORCE = 1, 3
NET_FIELDS = (_FOUND | _FORCE | _POS)
"""found (1), net force (3, global frame), force-weighted centroid (3)."""
NEAR_FIELDS = (_FOUND | _FORCE | _DIST | _POS | _NORMAL)
"""found (1), force in the contact frame (3), distance (1), point (3), normal (3)."""


@dataclass(frozen=True)
class FingertipGeometry:
    """The numbers of the attached fingertip, in metres in its own frame."""

    half_width: float
    root_z: float
    """Prism root (top of the base) above the base's underside."""
    nail_tip_z: float
    skirt_z: float
    top_z: float
    nail_x: tuple[float, float]
    nail_half_y: float
    nail_z: tuple[float, float]

    def height_below_nail_mm(self, z_m: float) -> float:
        """The strain model's contact height: millimetres below the nail tip."""
        return (self.nail_tip_z - z_m) * 1e3


@dataclass(frozen=True)
class AttachedFingertip:
    """Names of what :func:`attach_fingertip` added (look them up after compiling)."""

    name: str
    body: str
    geoms: tuple[str, ...]
    nail_geom: str
    net_sensor: str
    near_sensor: str
    geometry: FingertipGeometry


def geometry(params: FingertipParams | None = None) -> FingertipGeometry:
    """The fingertip's collision dimensions from ``fingertip.toml``."""
    p = params or load_params()
    g, cad = p.geometry, p.cad
    mm = 1e-3
    root = g.base_height_mm * mm
    nail_tip = root + g.nail_tip_z_mm * mm
    half = g.outer_width_mm / 2 * mm
    cap_half = half - g.skin_mm * mm
    return FingertipGeometry(
        half_width=half, root_z=root, nail_tip_z=nail_tip,
        skirt_z=root + cad.cap_base_clearance_mm * mm,
        top_z=nail_tip + g.skin_mm * mm,
        nail_x=(cap_half, half + g.nail_proud_mm * mm),
        nail_half_y=cad.nail_width_mm / 2 * mm,
        nail_z=(nail_tip - cad.nail_height_mm * mm, nail_tip))


def _box(body, name: str, lo: tuple[float, float, float], hi: tuple[float, float, float],
         mass: float, friction: float, solref: tuple[float, float],
         solimp: tuple[float, ...] | None, rgba: tuple[float, ...]):
    mj = mujoco()
    geom = body.add_geom(
        name=name, type=mj.mjtGeom.mjGEOM_BOX,
        size=[(h - lo_) / 2 for lo_, h in zip(lo, hi, strict=True)],
        pos=[(h + lo_) / 2 for lo_, h in zip(lo, hi, strict=True)],
        mass=mass, rgba=list(rgba), condim=3)
    geom.friction = [friction, 0.005, 0.0001]
    geom.solref = list(solref)
    if solimp is not None:
        geom.solimp = list(solimp)
    return geom


def attach_fingertip(spec, body: str, name: str = "fingertip", *,
                     pos: tuple[float, float, float] = (0.0, 0.0, 0.0),
                     quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0),
                     params: FingertipParams | None = None) -> AttachedFingertip:
    """Add a fingertip to ``body`` of ``spec`` (an ``mujoco.MjSpec``), in place.

    Returns the names of its body, geoms and contact sensors; after ``spec.compile()``, give
    it with the model and data to :class:`~fingertip.sim.mujoco.FingertipSensor`.
    """
    mj = mujoco()
    parent = spec.body(body)
    if parent is None:
        names = ", ".join(b.name for b in spec.bodies if b.name) or "none"
        raise ValueError(f"no body {body!r} in the model (bodies: {names})")
    if spec.body(name) is not None:
        raise ValueError(f"the model already has a body named {name!r}")
    p = params or load_params()
    geo = geometry(p)
    skin = load_realism().skin
    tip = parent.add_body(name=name, pos=list(pos), quat=list(quat))
    h, r, top = geo.half_width, geo.root_z, geo.top_z
    base_mass = TPU_KG_M3 * (2 * h) ** 2 * r
    shell = (2 * h) ** 2 * (top - geo.skirt_z) \
        - (2 * geo.nail_x[0]) ** 2 * (geo.nail_tip_z - geo.skirt_z)
    side, length = p.geometry.prism_side_mm * 1e-3, p.geometry.prism_length_mm * 1e-3
    cap_wall = p.geometry.cap_wall_mm * 1e-3
    inner = geo.nail_x[0] - cap_wall
    cap = (2 * geo.nail_x[0]) ** 2 * (geo.nail_tip_z - geo.skirt_z) \
        - (2 * inner) ** 2 * (geo.nail_tip_z - geo.skirt_z - p.geometry.cap_roof_mm * 1e-3)
    skin_mass = SILICONE_KG_M3 * shell + PLA_KG_M3 * (cap + side ** 2 * length)
    nail_mass = PLA_KG_M3 * (geo.nail_x[1] - geo.nail_x[0]) * 2 * geo.nail_half_y \
        * (geo.nail_z[1] - geo.nail_z[0])
    width = p.geometry.skin_mm * 1e-3
    names = (f"{name}/base", f"{name}/skin", f"{name}/nail")
    _box(tip, names[0], (-h, -h, 0.0), (h, h, r), base_mass, skin.friction, NAIL_SOLREF, None,
         (0.2, 0.2, 0.25, 1))
    _box(tip, names[1], (-h, -h, geo.skirt_z), (h, h, top), skin_mass, skin.friction,
         SKIN_SOLREF, (0.9, 0.99, width, 0.5, 2.0), (0.85, 0.55, 0.45, 1))
    _box(tip, names[2], (geo.nail_x[0], -geo.nail_half_y, geo.nail_z[0]),
         (geo.nail_x[1], geo.nail_half_y, geo.nail_z[1]), nail_mass, PLA_FRICTION,
         NAIL_SOLREF, None, (0.95, 0.95, 0.9, 1))
    sensors = (f"{name}/contact_net", f"{name}/contact_near")
    for sname, fields, reduce in ((sensors[0], NET_FIELDS, _NETFORCE),
                                  (sensors[1], NEAR_FIELDS, _MINDIST)):
        s = spec.add_sensor(name=sname, type=mj.mjtSensor.mjSENS_CONTACT,
                            objtype=mj.mjtObj.mjOBJ_BODY, objname=name)
        s.intprm[:3] = [fields, reduce, 1]
    return AttachedFingertip(name, name, names, names[2], sensors[0], sensors[1], geo)


def attach_fingertips(spec, bodies, *, pos: tuple[float, float, float] = (0.0, 0.0, 0.0),
                      quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0),
                      params: FingertipParams | None = None) -> dict[str, AttachedFingertip]:
    """A fingertip on each of ``bodies`` (body names: the distal links of a hand), all at
    the same ``pos`` and ``quat`` in their body's frame; named ``<body>_fingertip``.

    Returns them by body name. Bodies are checked before anything is added, so a typo adds
    nothing."""
    missing = [b for b in bodies if spec.body(b) is None]
    if missing:
        names = ", ".join(b.name for b in spec.bodies if b.name) or "none"
        raise ValueError(f"no body {', '.join(map(repr, missing))} in the model "
                         f"(bodies: {names})")
    return {b: attach_fingertip(spec, b, f"{b}_fingertip", pos=pos, quat=quat, params=params)
            for b in bodies}
