"""Read the fingertip PCB's outline and holes from a .kicad_pcb file (a small s-expression
reader: no KiCad needed), in the fingertip frame.

KiCad's y axis points down the page; the board is drawn seen from its top side, which faces
the base. The fingertip frame's origin is the prism axis: the board's aux origin when it is set,
otherwise the centre of the M2 mounting holes (they sit on a circle around it), so
x = X - cx and y = -(Y - cy).
"""
from __future__ import annotations

import math
import re
from itertools import pairwise
from dataclasses import dataclass, field
from pathlib import Path

Sexp = list  # nested lists of str

_TOKEN = re.compile(r'\(|\)|"(?:\\.|[^"\\])*"|[^\s()"]+')


def parse_sexp(text: str) -> Sexp:
    stack: list[list] = [[]]
    for tok in _TOKEN.findall(text):
        if tok == "(":
            stack.append([])
        elif tok == ")":
            node = stack.pop()
            stack[-1].append(node)
        else:
            stack[-1].append(tok[1:-1] if tok.startswith('"') else tok)
    return stack[0][0]


def _find(node: Sexp, key: str) -> list[Sexp]:
    return [c for c in node if isinstance(c, list) and c and c[0] == key]


def _one(node: Sexp, key: str) -> Sexp | None:
    found = _find(node, key)
    return found[0] if found else None


def _xy(node: Sexp | None) -> tuple[float, float]:
    return (float(node[1]), float(node[2])) if node else (0.0, 0.0)


def _layer(node: Sexp) -> str:
    n = _one(node, "layer")
    return n[1] if n else ""


@dataclass
class Board:
    outline: list[tuple[float, float]]                   # sampled Edge.Cuts points (KiCad)
    holes: list[tuple[float, float, float]]              # (X, Y, drill) of M2-size holes
    top_points: list[tuple[float, float]] = field(default_factory=list)  # F-side pads, bodies
    centre: tuple[float, float] | None = None

    def to_frame(self, pts):
        cx, cy = self.centre
        return [(x - cx, -(y - cy)) for x, y in pts]


def _arc_points(start, mid, end, step_mm: float = 0.1) -> list[tuple[float, float]]:
    """Points along the circular arc through start, mid, end."""
    (x1, y1), (x2, y2), (x3, y3) = start, mid, end
    d = 2 * (x1 * (y2 - y3) + x2 * (y3 - y1) + x3 * (y1 - y2))
    if abs(d) < 1e-12:
        return [start, end]
    ux = ((x1 ** 2 + y1 ** 2) * (y2 - y3) + (x2 ** 2 + y2 ** 2) * (y3 - y1)
          + (x3 ** 2 + y3 ** 2) * (y1 - y2)) / d
    uy = ((x1 ** 2 + y1 ** 2) * (x3 - x2) + (x2 ** 2 + y2 ** 2) * (x1 - x3)
          + (x3 ** 2 + y3 ** 2) * (x2 - x1)) / d
    r = math.hypot(x1 - ux, y1 - uy)
    a1, a2, a3 = (math.atan2(y - uy, x - ux) for x, y in (start, mid, end))
    sweep = (a3 - a1) % (2 * math.pi)
    if (a2 - a1) % (2 * math.pi) > sweep:     # the arc goes the other way round
        sweep -= 2 * math.pi
    n = max(2, int(abs(sweep) * r / step_mm) + 1)
    return [(ux + r * math.cos(a1 + sweep * k / n), uy + r * math.sin(a1 + sweep * k / n))
            for k in range(n + 1)]


def _segment_points(a, b, step_mm: float = 0.1) -> list[tuple[float, float]]:
    n = max(1, int(math.dist(a, b) / step_mm))
    return [(a[0] + (b[0] - a[0]) * k / n, a[1] + (b[1] - a[1]) * k / n) for k in range(n + 1)]


def _shape_points(node: Sexp) -> list[tuple[float, float]]:
    kind = node[0]
    if kind in ("gr_line", "fp_line"):
        return _segment_points(_xy(_one(node, "start")), _xy(_one(node, "end")))
    if kind in ("gr_arc", "fp_arc"):
        return _arc_points(_xy(_one(node, "start")), _xy(_one(node, "mid")),
                           _xy(_one(node, "end")))
    if kind in ("gr_rect", "fp_rect"):
        (x0, y0), (x1, y1) = _xy(_one(node, "start")), _xy(_one(node, "end"))
        corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)]
        return [p for a, b in pairwise(corners) for p in _segment_points(a, b)]
    if kind in ("gr_poly", "fp_poly"):
        pts = [_xy(c) for c in _one(node, "pts")[1:] if c[0] == "xy"]
        pts.append(pts[0])
        return [p for a, b in pairwise(pts) for p in _segment_points(a, b)]
    if kind in ("gr_circle", "fp_circle"):
        (cx, cy), (ex, ey) = _xy(_one(node, "center")), _xy(_one(node, "end"))
        r = math.hypot(ex - cx, ey - cy)
        return [(cx + r * math.cos(t), cy + r * math.sin(t))
                for t in [2 * math.pi * k / 360 for k in range(361)]]
    return []


def _rotate(x: float, y: float, deg: float) -> tuple[float, float]:
    """KiCad's rotation (counter-clockwise on screen, y down)."""
    a = math.radians(deg)
    return (x * math.cos(a) + y * math.sin(a), -x * math.sin(a) + y * math.cos(a))


def read_board(path: str | Path, hole_drill_range: tuple[float, float] = (1.9, 3.0)) -> Board:
    root = parse_sexp(Path(path).read_text(encoding="utf-8"))
    pieces: list[list[tuple[float, float]]] = []
    for node in root:
        if isinstance(node, list) and node and node[0].startswith("gr_") \
                and _layer(node) == "Edge.Cuts":
            pieces.append(_shape_points(node))
    holes, top = [], []
    for fp in _find(root, "footprint"):
        at = _one(fp, "at")
        fx, fy = _xy(at)
        fa = float(at[3]) if at and len(at) > 3 else 0.0
        fp_top = _layer(fp) == "F.Cu"
        fp_points: list[tuple[float, float]] = []
        is_hole = False
        for item in fp:
            if not isinstance(item, list) or not item:
                continue
            if item[0] == "pad":
                pat = _one(item, "at")
                px, py = _rotate(*_xy(pat), fa)
                x, y = fx + px, fy + py
                drill = _one(item, "drill")
                if drill and len(drill) > 1 and drill[1] != "oval":
                    dia = float(drill[1])
                    if hole_drill_range[0] <= dia <= hole_drill_range[1]:
                        holes.append((x, y, dia))
                        is_hole = True
                        continue
                if fp_top and item[2] == "smd":
                    w, h = _xy(_one(item, "size"))
                    pa = float(pat[3]) if len(pat) > 3 else fa
                    for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                        cx, cy = _rotate(sx * w / 2, sy * h / 2, pa)
                        fp_points.append((x + cx, y + cy))
            elif fp_top and item[0].startswith("fp_") and _layer(item) == "F.Fab":
                # The part's body outline (its fab drawing; the courtyard adds a margin).
                for px, py in _shape_points(item):
                    rx, ry = _rotate(px, py, fa)
                    fp_points.append((fx + rx, fy + ry))
            elif item[0].startswith("fp_") and _layer(item) == "Edge.Cuts":
                pieces.append([(fx + rx, fy + ry) for rx, ry in
                               (_rotate(px, py, fa) for px, py in _shape_points(item))])
        if not is_hole:          # a mounting hole's drawing is not a part in the pocket
            top += fp_points
    board = Board(outline=_chain([q for q in pieces if q]), holes=holes, top_points=top)
    setup = _one(root, "setup")
    aux = _one(setup, "aux_axis_origin") if setup else None
    if aux and _xy(aux) != (0.0, 0.0):
        # The board's designer put the aux origin on the prism axis (pcb/tools does).
        board.centre = _xy(aux)
    elif holes:
        board.centre = (sum(h[0] for h in holes) / len(holes), sum(h[1] for h in holes)
                        / len(holes))
    return board


def _chain(pieces: list[list[tuple[float, float]]], tol: float = 1e-3
           ) -> list[tuple[float, float]]:
    """Join outline pieces end to end (reversing them as needed) into one ordered loop; pieces
    that do not connect are appended as they are (the area check then fails loudly)."""
    if not pieces:
        return []
    loop = list(pieces[0])
    rest = [list(q) for q in pieces[1:]]
    while rest:
        end = loop[-1]
        nxt = next((q for q in rest if min(math.dist(q[0], end), math.dist(q[-1], end)) < tol),
                   None)
        if nxt is None:
            for q in rest:
                loop += q
            break
        rest.remove(nxt)
        loop += nxt[1:] if math.dist(nxt[0], end) < tol else nxt[::-1][1:]
    return loop


def polygon_area(pts: list[tuple[float, float]]) -> float:
    """Shoelace area of points in outline order (closed or not)."""
    s = 0.0
    for (x0, y0), (x1, y1) in zip(pts, pts[1:] + pts[:1], strict=True):
        s += x0 * y1 - x1 * y0
    return abs(s) / 2
