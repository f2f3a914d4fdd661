"""How the parts meet: the 1 mm gap, the nail, the gauges, the piezo, the screw, the mold."""
from __future__ import annotations

import itertools
import math

import pytest

from fingertip_cad import bought
from fingertip_cad.checks import common_volume, distance, first_hit_x, inside, point_distance
from fingertip_cad.solids import box

GAP_TOL = 1e-3   # mm, on exact BRep distances


def test_base_and_prism_are_two_bodies_of_one_print(cad):
    """They touch (the prism's root sits in the base's socket) but never overlap."""
    base, prism = cad.parts.base, cad.parts.prism
    assert common_volume(base, prism) == pytest.approx(0.0, abs=1e-6)
    assert distance(base, prism) == pytest.approx(0.0, abs=1e-6)
    d = cad.dims
    # The root really is embedded: a point of the prism below the base top is surrounded by
    # base material on all four sides.
    z = d.z_base_top - d.p.cad.prism_embed_mm / 2
    off = d.half_prism + 0.3
    # (probes beside the wire holes of the +x, +y and -x faces)
    for probe in ((off, -1.5, z), (1.5, off, z), (-off, -1.5, z), (0.0, -off, z)):
        assert inside(base, probe), probe


def test_the_cap_keeps_the_gap_on_all_four_sides(cad):
    d, cap, prism = cad.dims, cad.parts.cap, cad.parts.prism
    gap = d.p.geometry.cap_gap_mm
    # The skirt (the cap below the roof's underside) against the whole prism: exactly the gap.
    skirt = cap.intersect(box(-50, 50, -50, 50, -1, d.z_prism_top - 1e-3))
    assert distance(skirt, prism) == pytest.approx(gap, abs=GAP_TOL)
    # Everywhere along each face (off the wire channel), from the cap's rim to the roof.
    h = d.half_prism
    zs = [d.z_cap_bottom + 0.01, d.z_gauge, (d.z_gauge + d.z_prism_top) / 2,
          d.z_prism_top - gap - 0.01]   # (higher up, the roof is nearer than the wall)
    for z, t in itertools.product(zs, (-h + 0.1, h - 0.1)):
        for x, y in ((h, t), (-h, t), (t, h), (t, -h)):
            assert point_distance(cap, (x, y, z)) == pytest.approx(gap, abs=GAP_TOL), (x, y, z)


def test_the_cap_is_held_only_at_the_prism_top(cad):
    d, cap, prism = cad.dims, cad.parts.cap, cad.parts.prism
    assert common_volume(cap, prism) == pytest.approx(0.0, abs=1e-6)
    assert distance(cap, prism) == pytest.approx(0.0, abs=1e-6)
    # The roof's underside bears on the prism top (a ring around the screw hole).
    r = d.p.cad.screw_clearance_diameter_mm / 2
    for x, y in ((d.half_prism - 0.2, 0), (0, d.half_prism - 0.2), (-(r + 0.3), 0)):
        assert point_distance(cap, (x, y, d.z_prism_top)) == pytest.approx(0.0, abs=1e-6)
    # The skirt stays clear of the base by more than the gap (the prism bends freely).
    assert distance(cap, cad.parts.base) >= d.p.geometry.cap_gap_mm - GAP_TOL
    assert distance(cap, cad.parts.base) == pytest.approx(d.p.cad.cap_base_clearance_mm,
                                                          abs=GAP_TOL)


def test_the_screw_fits(cad):
    d, screw = cad.dims, cad.parts.screw
    assert common_volume(screw, cad.parts.cap) == pytest.approx(0.0, abs=1e-6)
    # Its tip stays above the bottom of the pilot hole, its thread engages the prism.
    bottom = screw.BoundingBox().zmin
    assert bottom > d.z_prism_top - d.p.cad.screw_pilot_depth_mm
    assert d.z_prism_top - bottom >= 1.5 * d.p.cad.screw_pilot_diameter_mm
    # Head flush with the seat floor, under the disc.
    assert screw.BoundingBox().zmax == pytest.approx(d.z_seat_floor, abs=1e-6)
    assert common_volume(screw, cad.parts.piezo) == pytest.approx(0.0, abs=1e-6)


def test_the_nail_stands_1mm_proud_of_the_skin(cad):
    d = cad.dims
    cap, skin = cad.mesh("cap"), cad.mesh("skin")
    proud = d.p.geometry.nail_proud_mm
    w = d.p.cad.nail_width_mm / 2
    z_mid = (d.z_nail_bottom + d.z_nail_top) / 2
    for y in (-0.8 * w, 0.0, 0.8 * w):
        nail_x = first_hit_x(cap, y, z_mid)
        skin_x = first_hit_x(skin, y + (w + 1.0 if y >= 0 else -w - 1.0), z_mid)
        assert nail_x - skin_x == pytest.approx(proud, abs=0.05)
    # The skin leaves the nail bare and the nail's tip is at the physics model's nail tip.
    assert common_volume(cad.parts.skin, cad.parts.cap) == pytest.approx(0.0, abs=1e-6)
    zmax_out = cap.vertices[cap.vertices[:, 0] > d.half_skin + 1e-6][:, 2].max()
    assert zmax_out - d.z_base_top == pytest.approx(d.p.geometry.nail_tip_z_mm, abs=1e-6)


def test_the_skin_has_its_thickness(cad):
    d, skin = cad.dims, cad.mesh("skin")
    g = d.p.geometry
    # Sides (away from the nail): skin_mm over the cap.
    z = (d.z_cap_bottom + d.z_nail_bottom) / 2
    assert first_hit_x(skin, 0.0, z) == pytest.approx(d.half_skin, abs=0.01)
    h = d.half_cap
    for x, y in ((0, h + g.skin_mm / 2), (0, -h - g.skin_mm / 2), (-h - g.skin_mm / 2, 0)):
        assert inside(cad.parts.skin, (x, y, z))
        assert point_distance(cad.parts.cap, (x, y, z)) == pytest.approx(g.skin_mm / 2, abs=1e-6)
    # Top: the envelope stacks the disc and skin_mm on the roof; the disc sits in its seat,
    # so the skin over it is skin_mm + the seat's depth.
    disc_top = cad.parts.piezo.BoundingBox().zmax
    assert d.z_skin_top - disc_top == pytest.approx(g.skin_mm + d.p.cad.piezo_seat_depth_mm,
                                                    abs=1e-6)
    assert d.z_skin_top - d.z_roof_top == pytest.approx(g.skin_mm + d.p.piezo.thickness_mm)


@pytest.mark.parametrize("channel", range(4))
def test_each_gauge_lies_flat_on_its_face(cad, channel):
    d, prism = cad.dims, cad.parts.prism
    backing = bought.gauge_backing(d, channel)
    assert backing.BoundingBox().zlen == pytest.approx(cad.dims.p.gauge.backing_length_mm)
    assert common_volume(backing, prism) == pytest.approx(0.0, abs=1e-9)
    assert distance(backing, prism) == pytest.approx(0.0, abs=1e-9)
    # A slab under the whole backing, 0.02 mm into the face, is all prism: the face is flat
    # and solid there (no channel, no hole, no edge).
    slab = bought.gauge_backing(d, channel, thickness=0.01, inset=0.02)
    assert common_volume(slab, prism) == pytest.approx(slab.Volume(), rel=1e-6)
    # Above the base, inside the gap, clear of the cap.
    assert common_volume(backing, cad.parts.base) == pytest.approx(0.0, abs=1e-9)
    assert distance(backing, cad.parts.cap) > d.p.geometry.cap_gap_mm - 0.1


def test_the_wire_channels_reach_the_wire_holes(cad):
    """From each face's channel, a wire can run down into the pocket: probe points along the
    channel's path are in neither body (the groove) and the wire hole is open to the pocket."""
    from fingertip_cad.dims import GAUGE_WIRE_HOLE

    d = cad.dims
    depth = d.p.cad.wire_channel_depth_mm
    for ch in range(4):
        path = d.channel_path(ch)
        for (ax, ay), (bx, by) in itertools.pairwise(path):
            for t in (0.0, 0.5, 1.0):
                p = (ax + t * (bx - ax), ay + t * (by - ay), d.z_base_top - depth / 2)
                assert not inside(cad.parts.base, p) and not inside(cad.parts.prism, p), (ch, p)
        hx, hy = d.p.mount.wire_holes_xy_mm()[GAUGE_WIRE_HOLE[ch]]
        for z in (d.p.mount.pocket_depth_mm - 0.1, d.z_prism_bottom, d.z_base_top - 0.1):
            assert not inside(cad.parts.base, (hx, hy, z))
        # The face channel runs from below the base top up to the backing's lower edge.
        n = [(1, 0), (0, 1), (-1, 0), (0, -1)][ch]
        x, y = (d.half_prism - depth / 2) * n[0], (d.half_prism - depth / 2) * n[1]
        assert not inside(cad.parts.prism, (x, y, d.z_channel_top - 0.05))
        assert inside(cad.parts.prism, (x, y, d.z_channel_top + 0.05))


def test_the_piezo_fits_its_seat(cad):
    d, cap, disc = cad.dims, cad.parts.cap, cad.parts.piezo
    bb = disc.BoundingBox()
    assert (bb.xlen, bb.ylen) == pytest.approx((d.p.piezo.diameter_mm,) * 2, abs=1e-6)
    assert common_volume(disc, cap) == pytest.approx(0.0, abs=1e-9)
    assert distance(disc, cap) == pytest.approx(0.0, abs=1e-9)     # resting on the floor
    assert bb.zmin == pytest.approx(d.z_seat_floor, abs=1e-9)
    # A disc 0.1 mm larger would still fit (the clearance is real), one the seat's size + 0.1
    # would not.
    from fingertip_cad.solids import zcyl
    z0, z1 = d.z_seat_floor + 1e-3, d.z_roof_top - 1e-3
    assert common_volume(zcyl(d.seat_x, 0, d.disc_radius + 0.1, z0, z1), cap) == 0.0
    assert common_volume(zcyl(d.seat_x, 0, d.seat_radius + 0.1, z0, z1), cap) > 0
    # The lead hole is under the disc and opens into the gap, not onto the prism.
    hx, hy = d.piezo_wire_hole_xy
    assert not inside(cap, (hx, hy, d.z_prism_top + 0.5))
    assert point_distance(cad.parts.prism, (hx, hy, d.z_prism_top + 0.01)) > 0.01
    assert inside(disc, (hx, hy, d.z_seat_floor + 0.1))


def test_the_mold_halves_close_without_overlap(cad):
    a, b = cad.parts.mold_a, cad.parts.mold_b
    assert common_volume(a, b) == pytest.approx(0.0, abs=1e-6)
    assert distance(a, b) == pytest.approx(0.0, abs=1e-9)
    # The pins enter the sockets with their clearance (they touch nothing in the +y half).
    c = cad.dims.p.cad
    for x, z in cad.dims.mold_key_xz:
        assert inside(a, (x, c.mold_key_length_mm / 2, z))
        assert not inside(b, (x, c.mold_key_length_mm / 2, z))
        # On the pin's axis near the parting plane, the socket's wall is the nearest.
        assert point_distance(b, (x, 0.1, z)) == pytest.approx(
            c.mold_key_diameter_mm / 2 + c.mold_key_clearance_mm, abs=1e-6)
    # The mold only touches the fingertip, never cuts into it.
    for name in ("base", "prism", "cap"):
        for half in (a, b):
            assert common_volume(half, getattr(cad.parts, name)) == pytest.approx(0, abs=1e-6)


def test_the_mold_cavity_is_the_skin(cad):
    """The space closed by the two halves around the core (cap, nail, disc, prism), up to the
    skin's top, is one cavity with exactly the skin's volume (a gap between the halves or a
    wrong cavity would change it); the pour and the vents open into it."""
    d, parts = cad.dims, cad.parts
    x0, x1 = d.mold_x
    region = box(x0, x1, -d.mold_y, d.mold_y, d.mold_z[0], d.z_skin_top)
    void = region.cut(parts.mold_a, parts.mold_b, parts.cap, parts.piezo, parts.prism)
    probe = (-d.half_cap - d.p.geometry.skin_mm / 2, 0.0, (d.z_cap_bottom + d.z_skin_top) / 2)
    cavities = [s for s in void.Solids() if s.isInside(_vec(probe))]
    assert len(cavities) == 1
    # The pour and the vents run through the +x wall, from the skin's face out: add them.
    c = d.p.cad
    channels = math.pi * (x1 - d.half_skin) * (
        (c.mold_pour_diameter_mm / 2) ** 2
        + sum((c.mold_vent_diameter_mm / 2) ** 2 for _ in d.mold_vent_z))
    assert cavities[0].Volume() - channels == pytest.approx(parts.skin.Volume(), rel=1e-3)
    # No silicone reaches the gap: the cup's inside is a separate, sealed space.
    inner = (0.0, d.half_prism + d.p.geometry.cap_gap_mm / 2, d.z_gauge)
    assert not cavities[0].isInside(_vec(inner))
    # Pour and vents connect the cavity to the outside through the +x wall.
    for z, r in [(d.mold_pour_z, c.mold_pour_diameter_mm / 2)] + \
            [(z, c.mold_vent_diameter_mm / 2) for z in d.mold_vent_z]:
        for x in (d.half_skin + 0.5, x1 - 0.5):
            for half in (parts.mold_a, parts.mold_b):
                assert not inside(half, (x, 0.0, z)), (x, z)
        assert inside(parts.mold_a, (x1 - 0.5, -r - 0.3, z))


def _vec(p):
    import cadquery as cq

    return cq.Vector(*p)
