"""The triangular TPU base and the square PLA prism: two bodies of one dual-material print.

The prism's root sits in a square socket of the base (prism_embed_mm deep), so the two bodies
touch but never overlap and a slicer aligns them from their shared frame. The base carries the
fingertip PCB underneath (M2 pilots on the [mount] pattern, a pocket for the PCB's top-side
parts open towards the -y edge for the FFC) and brings the gauge leads from grooves at the
prism's foot down wire holes into that pocket.
"""
from __future__ import annotations

import cadquery as cq

from .dims import Dims
from .solids import box, cut, fuse, one_solid, polyline_channel, rounded_triangle, zcyl


def pocket(d: Dims) -> cq.Shape:
    """The pocket's volume: the base outline inset by pocket_wall_mm, a slot out through the
    -y edge for the cable, minus a boss around each mounting hole."""
    m = d.p.mount
    depth = m.pocket_depth_mm
    inner = rounded_triangle(d.pocket_inradius, d.pocket_corner_radius, -0.01, depth)
    slot = box(-d.slot_half_width, d.slot_half_width, -d.base_inradius - 1.0,
               -d.pocket_inradius + 0.5, -0.01, depth)
    bosses = [zcyl(x, y, d.boss_radius, -0.02, depth + 0.01) for x, y in m.mount_holes_xy_mm()]
    return cut(fuse([inner, slot]), bosses)


def wire_passages(d: Dims) -> list[cq.Solid]:
    """Vertical holes from the base top into the pocket; where a hole comes closer to the
    prism face than a printable wall, the strip between them is cut too (the hole's inner
    side is then the prism face itself, instead of a sliver of TPU)."""
    m, c = d.p.mount, d.p.cad
    r = m.wire_hole_diameter_mm / 2
    out = []
    for x, y in m.wire_holes_xy_mm():
        out.append(zcyl(x, y, r, m.pocket_depth_mm - 0.01, d.z_base_top + 0.01))
        along_x = abs(x) >= abs(y)
        gap = (abs(x) if along_x else abs(y)) - r - d.half_prism
        if gap < c.min_wall_mm:
            if along_x:
                face = d.half_prism if x > 0 else -d.half_prism
                out.append(box(face, x, y - r, y + r, m.pocket_depth_mm - 0.01, d.z_base_top))
            else:
                face = d.half_prism if y > 0 else -d.half_prism
                out.append(box(x - r, x + r, face, y, m.pocket_depth_mm - 0.01, d.z_base_top))
    return out


def base_channels(d: Dims) -> list[cq.Solid]:
    """Grooves on the base top from each face's foot to its wire hole."""
    c = d.p.cad
    z0, z1 = d.z_base_top - c.wire_channel_depth_mm, d.z_base_top + 0.01
    out: list[cq.Solid] = []
    for gauge in range(4):
        out += polyline_channel(d.channel_path(gauge), c.wire_channel_width_mm, z0, z1)
    return out


def base(d: Dims) -> cq.Solid:
    m, c = d.p.mount, d.p.cad
    body = rounded_triangle(d.base_inradius, m.base_corner_radius_mm, 0.0, d.z_base_top)
    socket = box(-d.half_prism, d.half_prism, -d.half_prism, d.half_prism,
                 d.z_prism_bottom, d.z_base_top + 0.01)
    pilots = [zcyl(x, y, m.mount_pilot_diameter_mm / 2, -0.01, c.mount_pilot_depth_mm)
              for x, y in m.mount_holes_xy_mm()]
    tools = [socket, pocket(d), *pilots, *wire_passages(d), *base_channels(d)]
    return one_solid(cut(body, tools), "base")


def face_channels(d: Dims) -> list[cq.Solid]:
    """Grooves down the middle of each prism face, from the gauge backing's lower edge to
    below the base top, where they open into the base's channels."""
    c = d.p.cad
    w, depth = c.wire_channel_width_mm / 2, c.wire_channel_depth_mm
    z0, z1 = d.z_base_top - depth, d.z_channel_top
    h = d.half_prism
    return [
        box(h - depth, h + 0.01, -w, w, z0, z1),
        box(-w, w, h - depth, h + 0.01, z0, z1),
        box(-h - 0.01, -h + depth, -w, w, z0, z1),
        box(-w, w, -h - 0.01, -h + depth, z0, z1),
    ]


def prism(d: Dims) -> cq.Solid:
    c = d.p.cad
    h = d.half_prism
    body = box(-h, h, -h, h, d.z_prism_bottom, d.z_prism_top)
    pilot = zcyl(0.0, 0.0, c.screw_pilot_diameter_mm / 2, d.z_prism_top - c.screw_pilot_depth_mm,
                 d.z_prism_top + 0.01)
    return one_solid(cut(body, [pilot, *face_channels(d)]), "prism")
