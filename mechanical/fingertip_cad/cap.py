"""The PLA cap: a square cup over the prism with the fingernail on its +x face.

The cap touches the prism only at the prism's top face, where the M2 screw clamps it; the
skirt keeps cap_gap_mm from all four prism faces and cap_base_clearance_mm from the base, so
the prism bends freely under a contact force. The roof holds the countersunk screw head and,
glued over it in a shallow seat, the piezo disc, whose leads go down a hole into the gap.
"""
from __future__ import annotations

import cadquery as cq

from .dims import Dims
from .solids import box, cone_z, cut, fuse, one_solid, zcyl


def nail(d: Dims) -> cq.Solid:
    """The fingernail: a plate from inside the cap wall out to nail_proud_mm beyond the skin,
    its top edge at the nail tip (the zero of the paper's contact heights)."""
    w = d.p.cad.nail_width_mm / 2
    inner = d.half_cap - d.p.geometry.cap_wall_mm / 2   # overlaps the wall: one solid
    return box(inner, d.nail_x_out, -w, w, d.z_nail_bottom, d.z_nail_top)


def cap_hull(d: Dims) -> cq.Shape:
    """The cap's outside as the skin and the mold see it: a block with the piezo seat."""
    block = box(-d.half_cap, d.half_cap, -d.half_cap, d.half_cap, d.z_cap_bottom, d.z_roof_top)
    seat = zcyl(d.seat_x, 0.0, d.seat_radius, d.z_seat_floor, d.z_roof_top + 0.01)
    # The seat is cut after the nail is added: the nail's inner end lies under the seat's rim.
    return fuse([block, nail(d)]).cut(seat)


def screw_hole(d: Dims) -> list[cq.Solid]:
    """Clearance hole and 90-degree countersink, flush with the seat floor."""
    c = d.p.cad
    rc = c.screw_clearance_diameter_mm / 2
    z_csk = d.z_seat_floor - c.countersink_depth_mm
    return [zcyl(0.0, 0.0, rc, d.z_prism_top - 0.01, z_csk + 0.01),
            cone_z(0.0, 0.0, rc, d.countersink_radius, z_csk, d.z_seat_floor),
            zcyl(0.0, 0.0, d.countersink_radius, d.z_seat_floor, d.z_roof_top + 0.01)]


def cap(d: Dims) -> cq.Solid:
    c = d.p.cad
    cavity = box(-d.half_cavity, d.half_cavity, -d.half_cavity, d.half_cavity,
                 d.z_cap_bottom - 0.01, d.z_prism_top)
    hx, hy = d.piezo_wire_hole_xy
    wire = zcyl(hx, hy, c.piezo_wire_hole_diameter_mm / 2, d.z_prism_top - 0.01,
                d.z_seat_floor + 0.01)
    return one_solid(cut(cap_hull(d), [cavity, wire, *screw_hole(d)]), "cap")
