"""The cast silicone skin (Mold Star 20T) and the piezo disc it covers.

The skin fills the outer_width square from the cap's rim to the envelope's top: skin_mm over
the cap's four sides; over the roof, piezo thickness + skin_mm (the envelope's stack), so
skin_mm + the seat's depth over the recessed disc; around the nail, which stays bare and stands
nail_proud_mm out of it.
"""
from __future__ import annotations

import cadquery as cq

from .cap import cap_hull
from .dims import Dims
from .solids import box, one_solid, zcyl


def piezo_disc(d: Dims) -> cq.Solid:
    """The 10 mm disc with its glue layer, resting on the seat floor."""
    return zcyl(d.seat_x, 0.0, d.disc_radius, d.z_seat_floor,
                d.z_seat_floor + d.p.piezo.thickness_mm)


def skin_block(d: Dims) -> cq.Solid:
    h = d.half_skin
    return box(-h, h, -h, h, d.z_cap_bottom, d.z_skin_top)


def skin(d: Dims) -> cq.Solid:
    return one_solid(skin_block(d).cut(cap_hull(d), piezo_disc(d)), "skin")
