"""Bought-in parts, modelled only as far as the fit checks and the assembly need them: the
gauge backings, the cap screw and the fingertip PCB's outline."""
from __future__ import annotations

import cadquery as cq

from .dims import Dims
from .solids import box, cone_z, cut, fuse, rounded_triangle, zcyl

GAUGE_THICKNESS_MM = 0.05   # foil + backing (BF120-3AA datasheet: polyimide backing)


def gauge_backing(d: Dims, channel: int, thickness: float = GAUGE_THICKNESS_MM,
                  inset: float = 0.0) -> cq.Solid:
    """Channel ``channel``'s backing (width x length) on its face, centred at z_gauge;
    ``inset`` > 0 pushes it that far into the prism (used to check the face is flat)."""
    g = d.p.gauge
    w, half_l = g.backing_width_mm / 2, g.backing_length_mm / 2
    z0, z1 = d.z_gauge - half_l, d.z_gauge + half_l
    a, b = d.half_prism - inset, d.half_prism - inset + thickness
    return [box(a, b, -w, w, z0, z1), box(-w, w, a, b, z0, z1),
            box(-b, -a, -w, w, z0, z1), box(-w, w, -b, -a, z0, z1)][channel]


def screw(d: Dims) -> cq.Shape:
    """M2 countersunk screw, head flush with the seat floor."""
    c = d.p.cad
    r = 1.0                                              # M2 thread, nominal
    z_csk = d.z_seat_floor - c.countersink_depth_mm
    shank = zcyl(0.0, 0.0, r, d.z_seat_floor - c.screw_length_mm, z_csk + 0.01)
    head = cone_z(0.0, 0.0, c.screw_clearance_diameter_mm / 2 - 0.05,
                  d.countersink_radius - 0.05, z_csk, d.z_seat_floor)
    return fuse([shank, head])


def pcb(d: Dims) -> cq.Shape:
    """The fingertip PCB as the [mount] contract describes it: the base outline, the M2
    clearance holes, below the base's underside."""
    m = d.p.mount
    board = rounded_triangle(d.base_inradius, m.base_corner_radius_mm, -m.pcb_thickness_mm, 0.0)
    holes = [zcyl(x, y, m.mount_clearance_diameter_mm / 2, -m.pcb_thickness_mm - 0.01, 0.01)
             for x, y in m.mount_holes_xy_mm()]
    return cut(board, holes)


