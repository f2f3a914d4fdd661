"""Small CadQuery helpers: primitives by their extents, and checked booleans."""
from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from itertools import pairwise

import cadquery as cq

Point = tuple[float, float]


def box(x0: float, x1: float, y0: float, y1: float, z0: float, z1: float) -> cq.Solid:
    """Axis-aligned box between two corners (any order)."""
    lo = (min(x0, x1), min(y0, y1), min(z0, z1))
    return cq.Solid.makeBox(abs(x1 - x0), abs(y1 - y0), abs(z1 - z0), cq.Vector(*lo))


def zcyl(x: float, y: float, r: float, z0: float, z1: float) -> cq.Solid:
    """Vertical cylinder from z0 to z1."""
    return cq.Solid.makeCylinder(r, z1 - z0, cq.Vector(x, y, z0), cq.Vector(0, 0, 1))


def cyl(start: Sequence[float], direction: Sequence[float], r: float, length: float
        ) -> cq.Solid:
    return cq.Solid.makeCylinder(r, length, cq.Vector(*start), cq.Vector(*direction))


def cone_z(x: float, y: float, r0: float, r1: float, z0: float, z1: float) -> cq.Solid:
    """Truncated cone along +z: radius r0 at z0, r1 at z1."""
    return cq.Solid.makeCone(r0, r1, z1 - z0, cq.Vector(x, y, z0), cq.Vector(0, 0, 1))


def rounded_triangle(inradius: float, corner_radius: float, z0: float, z1: float) -> cq.Shape:
    """Equilateral prism (apex +y, flat edge facing -y, incentre on the z axis) whose
    vertical edges are rounded: the exact offset by ``corner_radius`` of a triangle with
    inradius ``inradius - corner_radius``."""
    r = 2 * inradius
    pts = [(r * math.cos(math.radians(a)), r * math.sin(math.radians(a)))
           for a in (90.0, 210.0, 330.0)]
    wp = cq.Workplane("XY", origin=(0, 0, z0)).polyline(pts).close().extrude(z1 - z0)
    if corner_radius > 0:
        wp = wp.edges("|Z").fillet(corner_radius)
    return wp.val()


def polyline_channel(points: Sequence[Point], width: float, z0: float, z1: float
                     ) -> list[cq.Solid]:
    """Boxes along an axis-aligned polyline (a groove of ``width``), with square ends that
    overlap at the corners."""
    out = []
    h = width / 2
    for (ax, ay), (bx, by) in pairwise(points):
        if math.hypot(bx - ax, by - ay) < 1e-9:
            continue
        if abs(ay - by) < 1e-9:        # along x
            out.append(box(min(ax, bx) - h, max(ax, bx) + h, ay - h, ay + h, z0, z1))
        elif abs(ax - bx) < 1e-9:      # along y
            out.append(box(ax - h, ax + h, min(ay, by) - h, max(ay, by) + h, z0, z1))
        else:
            raise ValueError("channel segments must be parallel to x or y")
    return out


def cut(shape: cq.Shape, tools: Iterable[cq.Shape]) -> cq.Shape:
    tools = list(tools)
    return shape.cut(*tools) if tools else shape


def fuse(shapes: Iterable[cq.Shape]) -> cq.Shape:
    first, *rest = list(shapes)
    return first.fuse(*rest) if rest else first


def one_solid(shape: cq.Shape, name: str) -> cq.Solid:
    """The single valid solid of ``shape`` (merged faces), or a clear error."""
    solids = shape.clean().Solids()
    if len(solids) != 1:
        raise ValueError(f"{name}: expected one solid, got {len(solids)}")
    solid = solids[0]
    if not solid.isValid():
        raise ValueError(f"{name}: the solid is not valid")
    return solid
