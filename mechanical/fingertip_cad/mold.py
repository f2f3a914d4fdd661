"""The two-part mold that casts the skin over the assembled fingertip, the cap as its core.

The halves split on the y = 0 plane and slide on from -y and +y: each holds half of the skin's
cavity, half of the nail's pocket (the nail's outer face rests on the mold, so it stays bare)
and a floor that fills the slot between the cap's rim and the base, with a notch for the
prism. The cap's rim seals on that floor, so no silicone gets into the gap around the prism.
Three pins on the -y half enter sockets in the +y half (an asymmetric pattern). The mold is
filled lying on its -x side: the pour channel and two vents run through the +x wall, so the
skin's +x face (the highest surface) is vented and no air is trapped under the nail.
"""
from __future__ import annotations

import cadquery as cq

from .cap import nail
from .dims import Dims
from .skin import skin_block
from .solids import box, cut, cyl, one_solid


def mold_block(d: Dims) -> cq.Solid:
    x0, x1 = d.mold_x
    z0, z1 = d.mold_z
    return box(x0, x1, -d.mold_y, d.mold_y, z0, z1)


def mold_voids(d: Dims) -> list[cq.Shape]:
    """Everything the halves leave empty: the skin's block, the nail, the floor's notch around
    the prism, the pour channel and the vents."""
    c = d.p.cad
    notch = box(-d.half_cavity, d.half_cavity, -d.half_cavity, d.half_cavity,
                d.z_base_top - 0.01, d.z_cap_bottom + 0.01)
    x_in, x_out = d.half_skin - 0.01, d.mold_x[1] + 0.01
    pour = cyl((x_in, 0.0, d.mold_pour_z), (1, 0, 0), c.mold_pour_diameter_mm / 2, x_out - x_in)
    vents = [cyl((x_in, 0.0, z), (1, 0, 0), c.mold_vent_diameter_mm / 2, x_out - x_in)
             for z in d.mold_vent_z]
    return [skin_block(d), nail(d), notch, pour, *vents]


def _keys(d: Dims, extra: float) -> list[cq.Solid]:
    c = d.p.cad
    r = c.mold_key_diameter_mm / 2 + extra
    start = -0.01 if extra else -c.mold_key_length_mm / 2   # pins root inside the -y half
    length = c.mold_key_length_mm + extra - start
    return [cyl((x, start, z), (0, 1, 0), r, length) for x, z in d.mold_key_xz]


def mold_halves(d: Dims) -> tuple[cq.Solid, cq.Solid]:
    """(-y half with the pins, +y half with the sockets)."""
    body = cut(mold_block(d), mold_voids(d))
    x0, x1 = d.mold_x
    z0, z1 = d.mold_z
    big = d.mold_y + 1.0
    minus = body.intersect(box(x0 - 1, x1 + 1, -big, 0.0, z0 - 1, z1 + 1))
    plus = body.intersect(box(x0 - 1, x1 + 1, 0.0, big, z0 - 1, z1 + 1))
    minus = minus.fuse(*_keys(d, 0.0))
    plus = plus.cut(*_keys(d, d.p.cad.mold_key_clearance_mm))
    return one_solid(minus, "mold_a"), one_solid(plus, "mold_b")
