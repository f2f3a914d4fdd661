"""Derived dimensions of every part, from the parameters alone (no CadQuery here).

All lengths in mm, in the fingertip frame: origin on the prism axis in the base's underside
plane, +z up, +x the outward normal of channel 0's face. z levels:

    0                 base underside (the fingertip PCB is screwed below it)
    pocket_depth      ceiling of the pocket for the PCB's top-side parts
    z_prism_bottom    the PLA prism's root, embedded in the TPU base
    z_base_top        base top = prism root = z = 0 of the physics model (lever arms)
    z_cap_bottom      rim of the cap skirt (the mold's floor fills the slot below it)
    z_gauge           centre of the gauge grids
    z_prism_top       prism top = underside of the cap roof (the only contact: the screw)
    z_nail_top        fingernail tip = the cap's top edge (contact heights count down from it)
    z_roof_top        top of the cap roof (piezo seat recessed into it)
    z_skin_top        top of the skin = outer_height_mm (the envelope's height)

Envelope: the skin is outer_width x outer_width (19 x 19 mm) from the cap rim to
outer_height (27 mm above the base's underside); the fingernail stands nail_proud_mm out of
the skin on the +x face only, so the overall size across x is outer_width + nail_proud.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

from fingertip.hardware.params import FingertipParams

# Which base wire hole (index into [mount] wire_hole_x/y_mm) each gauge's leads go down
# through, as the [mount] section specifies: gauges 0 and 3 the +x hole, gauge 1 (and the
# piezo pair) the +y hole, gauge 2 the -x hole; the -y side stays free for the FFC.
GAUGE_WIRE_HOLE = (0, 1, 2, 0)
PIEZO_WIRE_HOLE = 1

Point = tuple[float, float]


@dataclass(frozen=True)
class Dims:
    """Every derived dimension the parts use; ``Dims(params)`` validates the set."""

    p: FingertipParams

    def __post_init__(self) -> None:
        problems = self.problems()
        if problems:
            raise ValueError("parameters cannot be built: " + "; ".join(problems))

    # --- heights ----------------------------------------------------------------------------

    @property
    def z_base_top(self) -> float:
        return self.p.geometry.base_height_mm

    @property
    def z_prism_bottom(self) -> float:
        return self.z_base_top - self.p.cad.prism_embed_mm

    @property
    def z_prism_top(self) -> float:
        return self.z_base_top + self.p.geometry.prism_length_mm

    @property
    def z_roof_top(self) -> float:
        return self.z_prism_top + self.p.geometry.cap_roof_mm

    @property
    def z_cap_bottom(self) -> float:
        return self.z_base_top + self.p.cad.cap_base_clearance_mm

    @property
    def z_nail_top(self) -> float:
        return self.z_base_top + self.p.geometry.nail_tip_z_mm

    @property
    def z_nail_bottom(self) -> float:
        return self.z_nail_top - self.p.cad.nail_height_mm

    @property
    def z_skin_top(self) -> float:
        return self.p.geometry.outer_height_mm

    @property
    def z_gauge(self) -> float:
        return self.z_base_top + self.p.geometry.gauge_center_z_mm

    @property
    def z_seat_floor(self) -> float:
        return self.z_roof_top - self.p.cad.piezo_seat_depth_mm

    @property
    def z_channel_top(self) -> float:
        """Upper end of the wire channels on the prism faces: the gauge backing's lower edge."""
        return self.z_gauge - self.p.gauge.backing_length_mm / 2

    # --- half widths (centred on the prism axis) ---------------------------------------------

    @property
    def half_prism(self) -> float:
        return self.p.geometry.prism_side_mm / 2

    @property
    def half_cavity(self) -> float:
        """Inside of the cap skirt: the prism plus the gap on each side."""
        return self.half_prism + self.p.geometry.cap_gap_mm

    @property
    def half_cap(self) -> float:
        return self.half_cavity + self.p.geometry.cap_wall_mm

    @property
    def half_skin(self) -> float:
        return self.p.geometry.outer_width_mm / 2

    @property
    def nail_x_out(self) -> float:
        """Outer face of the nail: nail_proud_mm beyond the skin's +x face."""
        return self.half_skin + self.p.geometry.nail_proud_mm

    # --- roof: screw, piezo seat, wire exit ---------------------------------------------------

    @property
    def seat_radius(self) -> float:
        return self.p.piezo.diameter_mm / 2 + self.p.cad.piezo_seat_clearance_mm

    @property
    def disc_radius(self) -> float:
        return self.p.piezo.diameter_mm / 2

    @property
    def countersink_radius(self) -> float:
        return self.p.cad.screw_head_diameter_mm / 2

    @property
    def seat_x(self) -> float:
        """Seat centre on the x axis: towards the nail as far as the roof allows, while the
        disc still covers the screw head (the disc is glued over it after assembly)."""
        to_edge = self.half_cap - self.p.cad.min_wall_mm - self.seat_radius
        over_head = self.disc_radius - self.countersink_radius
        return max(0.0, min(to_edge, over_head))

    @property
    def piezo_wire_hole_xy(self) -> Point:
        """Through the roof into the gap on the +y side, under the disc (so no silicone runs
        into the gap), towards the +y base hole that carries the piezo pair."""
        g = self.p.geometry
        r = self.p.cad.piezo_wire_hole_diameter_mm / 2
        return (min(self.seat_x, self.half_cavity - r), self.half_prism + g.cap_gap_mm / 2)

    # --- base -------------------------------------------------------------------------------

    @property
    def base_inradius(self) -> float:
        return self.p.mount.base_inradius_mm

    @property
    def pocket_inradius(self) -> float:
        return self.base_inradius - self.p.cad.pocket_wall_mm

    @property
    def pocket_corner_radius(self) -> float:
        """The pocket is the base outline inset by pocket_wall_mm: an exact offset."""
        return max(0.0, self.p.mount.base_corner_radius_mm - self.p.cad.pocket_wall_mm)

    @property
    def boss_radius(self) -> float:
        """Solid material kept around each M2 pilot hole inside the pocket: only the minimum
        wall, so the pocket stays as wide as it can for the FFC connector between the two
        lower holes."""
        return self.p.mount.mount_pilot_diameter_mm / 2 + self.p.cad.min_wall_mm

    @property
    def slot_half_width(self) -> float:
        """Half width of the pocket's exit through the -y edge (FFC cable): out to the two
        lower mounting holes' centres (their bosses are cut out of it afterwards, so the exit
        is as wide as the bosses allow at each height), but min_wall_mm short of where the
        flat edge turns into the rounded corner, so no sliver is left there."""
        flat_end = math.sqrt(3) * (self.base_inradius - self.p.mount.base_corner_radius_mm)
        xs = [abs(x) for x, y in self.p.mount.mount_holes_xy_mm() if y < 0]
        return min([*xs, flat_end - self.p.cad.min_wall_mm])

    def triangle_vertices(self, inradius: float) -> list[Point]:
        """Equilateral triangle with this inradius, apex at +y, flat edge facing -y."""
        r = 2 * inradius
        return [(r * math.cos(math.radians(a)), r * math.sin(math.radians(a)))
                for a in (90.0, 210.0, 330.0)]

    def pocket_contains(self, xy: Point) -> bool:
        """Whether a top-side part of the fingertip PCB at ``xy`` (fingertip frame) is under
        the pocket: inside the base outline inset by pocket_wall_mm or in the cable exit, and
        outside the boss around each M2 pilot. Pure Python, for the PCB's own checks."""
        x, y = xy
        rc = self.pocket_corner_radius
        in_inset = _triangle_sd(xy, self.pocket_inradius - rc) - rc < 0
        in_exit = abs(x) < self.slot_half_width and y < -self.pocket_inradius + 0.5
        if not (in_inset or in_exit):
            return False
        return all(math.dist(xy, h) > self.boss_radius
                   for h in self.p.mount.mount_holes_xy_mm())

    def base_signed_distance(self, xy: Point) -> float:
        """Signed distance (mm, negative inside) from ``xy`` to the base's rounded outline."""
        rc = self.p.mount.base_corner_radius_mm
        return _triangle_sd(xy, self.base_inradius - rc) - rc

    # --- wire channels ----------------------------------------------------------------------

    @property
    def channel_ring(self) -> float:
        """Half size of the square the base-top channels follow around the prism foot: their
        inner edge is the prism face itself, so no sliver of TPU is left against it."""
        return self.half_prism + self.p.cad.wire_channel_width_mm / 2

    def channel_path(self, gauge: int) -> list[Point]:
        """Polyline of gauge ``gauge``'s channel on the base top, from the foot of its face to
        its wire hole, around the prism the short way."""
        h = self.channel_ring
        a = _ring_param((h * _COS[gauge], h * _SIN[gauge]), h)
        hole = self.p.mount.wire_holes_xy_mm()[GAUGE_WIRE_HOLE[gauge]]
        b = _ring_param(_ring_project(hole, h), h)
        pts = _ring_walk(a, b, h)
        if math.dist(pts[-1], hole) > 1e-9:
            pts.append(hole)
        return pts

    # --- mold -------------------------------------------------------------------------------

    @property
    def mold_x(self) -> tuple[float, float]:
        w = self.p.cad.mold_wall_mm
        return -self.half_skin - w, self.nail_x_out + w

    @property
    def mold_y(self) -> float:
        return self.half_skin + self.p.cad.mold_wall_mm

    @property
    def mold_z(self) -> tuple[float, float]:
        """From the base top (the floor fills the slot under the cap rim) to a roof."""
        return self.z_base_top, self.z_skin_top + self.p.cad.mold_wall_mm

    @property
    def mold_key_xz(self) -> list[Point]:
        """Three registration pins (an asymmetric pattern: the halves close one way only),
        in the side walls and the roof of the parting plane y = 0."""
        x0, x1 = self.mold_x
        w = self.p.cad.mold_wall_mm
        z_top = self.z_skin_top + w / 2
        z_low = self.z_cap_bottom + w / 2 + self.p.cad.mold_key_diameter_mm
        return [(x0 + w / 2, z_low), (x0 + w / 2, z_top), (x1 - w / 2, z_top)]

    @property
    def mold_pour_z(self) -> float:
        """Pour channel through the +x wall (the mold is filled lying on its -x side): midway
        between the floor and the nail."""
        return (self.z_cap_bottom + self.z_nail_bottom) / 2

    @property
    def mold_vent_z(self) -> list[float]:
        """Vents through the +x wall at both ends of the cavity (the highest surface while the
        mold lies on its side), clear of the nail's pocket."""
        r = self.p.cad.mold_vent_diameter_mm / 2
        return [self.z_cap_bottom + r + 0.3, self.z_skin_top - r - 0.05]

    # --- physics link -------------------------------------------------------------------------

    @property
    def strain_per_newton(self) -> float:
        """Surface strain per newton at the gauges (contact at the nail tip): the closed form of
        the virtual fingertip, ``FingertipParams.strain_per_newton``, from the same numbers."""
        return self.p.strain_per_newton

    # --- validation ---------------------------------------------------------------------------

    def problems(self) -> list[str]:
        """Geometric conflicts the scalar checks of the loader cannot see."""
        m, c = self.p.mount, self.p.cad
        wall = c.min_wall_mm
        out = []
        if m.base_corner_radius_mm < 0 or m.base_corner_radius_mm >= self.base_inradius:
            out.append("base_corner_radius_mm must be in [0, the base's inradius)")
        for i, (x, y) in enumerate(m.mount_holes_xy_mm()):
            edge = -self.base_signed_distance((x, y)) - m.mount_pilot_diameter_mm / 2
            if edge < wall:
                out.append(f"mount hole {i} leaves {edge:.2f} mm to the base's edge")
            prism = max(abs(x), abs(y)) - self.half_prism - self.boss_radius
            if prism < 0:
                out.append(f"mount hole {i} runs into the prism")
        r_wire = m.wire_hole_diameter_mm / 2
        pocket_edge = self.pocket_inradius - self.pocket_corner_radius
        for i, (x, y) in enumerate(m.wire_holes_xy_mm()):
            if max(abs(x), abs(y)) - r_wire < self.half_prism - 1e-9:
                out.append(f"wire hole {i} cuts into the prism")
            if _triangle_sd((x, y), pocket_edge) - self.pocket_corner_radius > -r_wire:
                out.append(f"wire hole {i} does not open into the pocket")
            for j, hole in enumerate(m.mount_holes_xy_mm()):
                if math.dist((x, y), hole) < self.boss_radius + r_wire:
                    out.append(f"wire hole {i} runs into mount hole {j}'s boss")
        if len(m.wire_hole_x_mm) <= max(GAUGE_WIRE_HOLE):
            out.append(f"need {max(GAUGE_WIRE_HOLE) + 1} wire holes in [mount]")
        if self.base_signed_distance((0.0, -self.channel_ring)) > -wall \
                or self.channel_ring + c.wire_channel_width_mm / 2 + wall > self.base_inradius:
            out.append("the wire channels around the prism foot leave too little base")
        if (self.slot_half_width - self.boss_radius) * 2 < m.ffc_pins * m.ffc_pitch_mm:
            out.append("the pocket's cable exit is narrower than the FFC")
        seat_edge = self.half_cap - (self.seat_x + self.seat_radius)
        if seat_edge < wall - 1e-9 or self.seat_x - self.seat_radius < -self.half_cap + wall:
            out.append("the piezo seat runs off the cap roof")
        if self.seat_x + self.countersink_radius > self.disc_radius + 1e-9:
            out.append("the piezo disc cannot cover the cap screw's head")
        hx, hy = self.piezo_wire_hole_xy
        if math.hypot(hx - self.seat_x, hy) + c.piezo_wire_hole_diameter_mm / 2 \
                > self.disc_radius:
            out.append("the piezo's wire hole is not under the disc")
        if c.nail_width_mm / 2 + wall > self.half_cap:
            out.append("the nail is wider than the cap")
        key_r = c.mold_key_diameter_mm / 2 + c.mold_key_clearance_mm
        for _x, z in self.mold_key_xz:
            if z - key_r < self.z_cap_bottom + wall:
                out.append("a mold key runs into the mold's floor")
        vent_r = c.mold_vent_diameter_mm / 2
        if self.mold_vent_z[1] - vent_r - self.z_nail_top < wall:
            out.append("the mold's top vent runs into the nail's pocket")
        if self.mold_pour_z + c.mold_pour_diameter_mm / 2 + wall > self.z_nail_bottom:
            out.append("the pour channel runs into the nail's pocket")
        if self.mold_vent_z[0] + vent_r + wall > self.mold_pour_z - c.mold_pour_diameter_mm / 2:
            out.append("the lower vent runs into the pour channel")
        return out

    @cached_property
    def summary(self) -> dict[str, float]:
        """Key numbers for logs and the docs."""
        g = self.p.geometry
        return {
            "envelope_x_mm": self.nail_x_out + self.half_skin,
            "envelope_y_mm": 2 * self.half_skin,
            "envelope_z_mm": self.z_skin_top,
            "cap_wall_mm": g.cap_wall_mm,
            "cap_gap_mm": g.cap_gap_mm,
            "lever_mm": g.lever_m(0.0) * 1e3,
            "strain_ue_per_n": self.strain_per_newton * 1e6,
        }


_COS = (1.0, 0.0, -1.0, 0.0)
_SIN = (0.0, 1.0, 0.0, -1.0)


def _triangle_sd(xy: Point, inradius: float) -> float:
    """Signed distance to an equilateral triangle (apex +y, incentre at the origin)."""
    x, y = xy
    normals = [(math.cos(math.radians(a)), math.sin(math.radians(a))) for a in (270, 30, 150)]
    d = [nx * x + ny * y - inradius for nx, ny in normals]
    if max(d) <= 0:
        return max(d)
    # Outside: distance to the nearest edge segment.
    r = 2 * inradius
    v = [(r * math.cos(math.radians(a)), r * math.sin(math.radians(a))) for a in (90, 210, 330)]
    best = math.inf
    for (ax, ay), (bx, by) in zip(v, v[1:] + v[:1], strict=True):
        ex, ey = bx - ax, by - ay
        t = max(0.0, min(1.0, ((x - ax) * ex + (y - ay) * ey) / (ex * ex + ey * ey)))
        best = min(best, math.hypot(x - ax - t * ex, y - ay - t * ey))
    return best


def _ring_project(xy: Point, h: float) -> Point:
    """Nearest point of the square ring of half size ``h`` (|x| = h or |y| = h)."""
    x, y = xy
    if abs(x) >= abs(y):
        return (math.copysign(h, x), max(-h, min(h, y)))
    return (max(-h, min(h, x)), math.copysign(h, y))


def _ring_param(xy: Point, h: float) -> float:
    """Perimeter coordinate on the ring, counter-clockwise from the corner (h, -h)."""
    x, y = xy
    if abs(x - h) < 1e-9 and y < h:
        return y + h
    if abs(y - h) < 1e-9 and x > -h:
        return 2 * h + (h - x)
    if abs(x + h) < 1e-9 and y > -h:
        return 4 * h + (h - y)
    return 6 * h + (x + h)


def _ring_point(t: float, h: float) -> Point:
    t %= 8 * h
    side, s = divmod(t, 2 * h)
    return [(h, -h + s), (h - s, h), (-h, h - s), (-h + s, -h)][int(side)]


def _ring_walk(a: float, b: float, h: float) -> list[Point]:
    """Points from ``a`` to ``b`` along the ring, the short way, with the corners between."""
    per = 8 * h
    fwd = (b - a) % per
    step = 1.0 if fwd <= per / 2 else -1.0
    length = fwd if step > 0 else per - fwd
    pts = [_ring_point(a, h)]
    corners = sorted(k * 2 * h for k in range(4))
    travelled = 0.0
    t = a
    while True:
        # Distance to the next corner in the walking direction.
        nxt = min(((c - t) * step) % per or per for c in corners)
        if travelled + nxt >= length - 1e-9:
            break
        travelled += nxt
        t += step * nxt
        pts.append(_ring_point(t, h))
    pts.append(_ring_point(b, h))
    return pts
