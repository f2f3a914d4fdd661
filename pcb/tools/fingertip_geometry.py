"""Geometry of the fingertip PCB, computed from fingertip.toml [mount] (pure Python).

Frame: the mechanical frame of [mount] (origin on the prism axis, +x = channel 0's face
normal, +y away from the FFC edge, mm). On the board: KiCad x = ORIGIN_X + x,
KiCad y = ORIGIN_Y - y (KiCad's y axis points down); the aux (drill/place) origin and the
grid origin sit on the prism axis, so plots and the STEP model use the mechanical frame.
Used by gen_fingertip.py (to build the board) and by tests/pcb (to check it).
"""
from __future__ import annotations

import importlib.util
import math
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
HARDWARE = REPO / "host" / "fingertip" / "hardware"
PARAMS_TOML = HARDWARE / "fingertip.toml"

ORIGIN_X = 100.0
ORIGIN_Y = 100.0

# Hirose FH12-8S-0.5SH(55) footprint (KiCad stdlib), in its own frame: contacts at y=-1.85,
# body front / actuator edge at y=+4.4, courtyard x +-5.05, y -3.0 .. +4.9.
FFC_FOOTPRINT = "Connector_FFC-FPC:Hirose_FH12-8S-0.5SH_1x08-1MP_P0.50mm_Horizontal"
FFC_FRONT = 4.4
FFC_COURT = (-5.05, -3.0, 5.05, 4.9)
# The actuator front stands this far inside the flat edge (negative: beyond it). -1.0: the
# body front (y=+3.4) is flush with the edge and the flip-lock actuator (1 mm) overhangs it,
# where it can be operated through the base's open pocket.
FFC_SETBACK = -1.0

# FFC pin-out (fingertip side; 0.5 mm pitch; pin 1 at mechanical -x).
FFC_PINOUT = {
    1: "G2",         # gauge 2 (-x face) signal
    2: "GAUGE_COM",  # common return of the four gauges (bridge E-, AGND on the readout)
    3: "GND",        # shield: ground pour of this board, GND on the readout
    4: "PIEZO_P",    # piezo disc, signal (guarded by GND and PIEZO_N on both sides)
    5: "PIEZO_N",    # piezo disc, return
    6: "G1",         # gauge 1 (+y face) signal
    7: "G0",         # gauge 0 (+x face) signal
    8: "G3",         # gauge 3 (-y face) signal
}

# Which wires come down which wire hole (index into [mount] wire_hole_*), as in the toml.
HOLE_WIRES = [
    [("G0", "gauge 0"), ("G3", "gauge 3"), ("GAUGE_COM", "gauges 0 and 3 return")],
    [("G1", "gauge 1"), ("GAUGE_COM", "gauge 1 return"), ("PIEZO_P", "piezo +"),
     ("PIEZO_N", "piezo -")],
    [("G2", "gauge 2"), ("GAUGE_COM", "gauge 2 return")],
]

PAD = 0.8          # square wire pad (mm)
PAD_PITCH = 1.05   # inside a cluster
PAD_COURT = 0.1    # courtyard margin of the wire pad footprint
# Pad corner to board edge: the pads must lie under the base's pocket, whose wall is
# [cad] pocket_wall_mm = 0.8 mm (tests/mechanical/test_pcb_fit.py checks the fit on the solid).
EDGE_KEEP = 0.85
HOLE_KEEP = 0.8    # pad edge to mounting-hole edge
CLUSTER_GAP = 0.6  # between clusters (a track passes)
MAX_PAD_TO_HOLE = 3.0


def load_params(path: str | Path | None = None):
    """The fingertip's parameters through the host package's ``hardware`` loader, loaded by
    path (standard library only): this tool runs under KiCad's Python, without the package."""
    import sys
    spec = importlib.util.spec_from_file_location(
        "_fingertip_hardware", HARDWARE / "__init__.py", submodule_search_locations=[str(HARDWARE)])
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod.load(Path(path) if path else PARAMS_TOML)


def to_board(x: float, y: float) -> tuple[float, float]:
    return (round(ORIGIN_X + x, 6), round(ORIGIN_Y - y, 6))


@dataclass
class Outline:
    lines: list       # ((x0, y0), (x1, y1)) mechanical
    arcs: list        # (start, mid, end, centre, radius) mechanical
    polygon: list     # dense polygon for distance checks


def outline(m) -> Outline:
    r_in = m.base_side_mm / (2 * math.sqrt(3))
    rc = m.base_corner_radius_mm
    d = 2 * (r_in - rc)             # corner arc centre from the incentre
    corners = [90.0, 210.0, 330.0]
    arcs = []
    for th in corners:
        c = (d * math.cos(math.radians(th)), d * math.sin(math.radians(th)))

        def on(a, c=c):
            return (c[0] + rc * math.cos(math.radians(a)), c[1] + rc * math.sin(math.radians(a)))
        arcs.append((on(th - 60), on(th), on(th + 60), c, rc))
    lines = [(arcs[i][2], arcs[(i + 1) % 3][0]) for i in range(3)]
    poly = []
    for i, th in enumerate(corners):
        c = arcs[i][3]
        for k in range(13):
            a = math.radians(th - 60 + 10 * k)
            poly.append((c[0] + rc * math.cos(a), c[1] + rc * math.sin(a)))
    return Outline(lines, arcs, poly)


def inside_distance(m, x: float, y: float) -> float:
    """Distance from (x, y) to the outline, positive inside (exact for the rounded triangle)."""
    r_in = m.base_side_mm / (2 * math.sqrt(3))
    rc = m.base_corner_radius_mm
    d = 2 * (r_in - rc)
    best = math.inf
    for th in (90.0, 210.0, 330.0):
        # in the corner's wedge: distance to the arc
        cx, cy = d * math.cos(math.radians(th)), d * math.sin(math.radians(th))
        vx, vy = x - cx, y - cy
        ang = math.degrees(math.atan2(vy, vx))
        if abs((ang - th + 180) % 360 - 180) <= 60 and math.hypot(vx, vy) > 0:
            best = min(best, rc - math.hypot(vx, vy))
    edges = min(r_in - (x * math.cos(math.radians(a)) + y * math.sin(math.radians(a)))
                for a in (-90.0, 30.0, 150.0))
    return min(best, edges) if best < math.inf else edges


def ffc_position(m) -> tuple[float, float]:
    """Mechanical (x, y) of the FFC footprint origin (rotation 0 on the board: the opening
    faces KiCad +y = mechanical -y, the flat edge)."""
    r_in = m.base_side_mm / (2 * math.sqrt(3))
    return (0.0, -(r_in - FFC_SETBACK - FFC_FRONT))


def ffc_courtyard(m) -> tuple[float, float, float, float]:
    """Mechanical x0, y0, x1, y1 of the FFC courtyard."""
    fx, fy = ffc_position(m)
    return (fx + FFC_COURT[0], fy - FFC_COURT[3], fx + FFC_COURT[2], fy - FFC_COURT[1])


def _pad_ok(m, x, y) -> bool:
    h = PAD / 2
    if inside_distance(m, x, y) < h * math.sqrt(2) + EDGE_KEEP:
        return False
    c = ffc_courtyard(m)
    reach = h + PAD_COURT + 0.05
    if c[0] - reach < x < c[2] + reach and c[1] - reach < y < c[3] + reach:
        return False
    rh = m.mount_clearance_diameter_mm / 2
    return all(math.hypot(x - hx, y - hy) >= rh + HOLE_KEEP + h * math.sqrt(2)
               for hx, hy in m.mount_holes_xy_mm())


def _arrangements(n: int) -> list[list[tuple[float, float]]]:
    """Cluster shapes to try (offsets from the centre): a row (each pad reachable from the
    FFC side), a column, 2 x 2."""
    p = PAD_PITCH
    row = [((k - (n - 1) / 2) * p, 0.0) for k in range(n)]
    col = [(0.0, -(k - (n - 1) / 2) * p) for k in range(n)]
    out = [row, col]
    if n == 4:
        out.append([(-p / 2, p / 2), (p / 2, p / 2), (-p / 2, -p / 2), (p / 2, -p / 2)])
    return out


def _cluster_offsets(n: int) -> list[tuple[float, float]]:
    return _arrangements(n)[0]


def wire_pads(m) -> list[dict]:
    """Pads: {'net', 'label', 'hole', 'x', 'y'} (mechanical), cluster by cluster."""
    holes = m.wire_holes_xy_mm()
    if len(holes) != len(HOLE_WIRES):
        raise ValueError(f"expected {len(HOLE_WIRES)} wire holes, got {len(holes)}")
    # Clusters with the fewest free positions first: the +y one sits on its hole.
    placed: list[tuple[float, float, float, float]] = []  # boxes
    pads = []
    order = sorted(range(len(holes)), key=lambda k: -_free_at(m, holes[k], len(HOLE_WIRES[k])))
    for k in order:
        hx, hy = holes[k]
        best = None
        step = 0.05
        for ring in range(0, 80):
            cands = []
            for offs, a in ((o, a) for o in _arrangements(len(HOLE_WIRES[k]))
                            for a in range(0, 360, 5)):
                cx = hx + ring * step * math.cos(math.radians(a))
                cy = hy + ring * step * math.sin(math.radians(a))
                if not all(_pad_ok(m, cx + ox, cy + oy) for ox, oy in offs):
                    continue
                h = PAD / 2
                box = (cx + min(o[0] for o in offs) - h, cy + min(o[1] for o in offs) - h,
                       cx + max(o[0] for o in offs) + h, cy + max(o[1] for o in offs) + h)
                if any(not (box[2] + CLUSTER_GAP <= b[0] or b[2] + CLUSTER_GAP <= box[0] or
                            box[3] + CLUSTER_GAP <= b[1] or b[3] + CLUSTER_GAP <= box[1])
                       for b in placed):
                    continue
                cands.append((cx, cy, box, offs))
            if cands:
                best = cands[0]
                break
        if best is None:
            raise ValueError(f"no room for the pads of wire hole {k} at {holes[k]}")
        cx, cy, box, offs = best
        placed.append(box)
        for (net, label), (ox, oy) in zip(HOLE_WIRES[k], offs, strict=False):
            pads.append({"net": net, "label": label, "hole": k, "x": round(cx + ox, 4),
                         "y": round(cy + oy, 4)})
    pads.sort(key=lambda p: (p["hole"], -p["y"], p["x"]))
    return pads


def _free_at(m, hole, n) -> int:
    return int(all(_pad_ok(m, hole[0] + ox, hole[1] + oy) for ox, oy in _cluster_offsets(n)))
