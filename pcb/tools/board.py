"""Build a .kicad_pcb with KiCad's own pcbnew module: stock footprints, nets from the
schematic, tracks from a small grid router (two layers, 45-degree moves, vias), GND zones
filled by KiCad. Run with Debian's /usr/bin/python3 (the kicad package ships pcbnew)."""
from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np
import pcbnew

FPDIR = "/usr/share/kicad/footprints"
MM = pcbnew.FromMM


def mm(v: int) -> float:
    return pcbnew.ToMM(v)


@dataclass
class Rules:
    track: float = 0.2
    clearance: float = 0.2
    via: float = 0.6
    drill: float = 0.3
    edge: float = 0.3
    hole_clearance: float = 0.25
    grid: float = 0.1


class Router:
    """Lee/A* maze router on a grid over both copper layers."""

    def __init__(self, x0: float, y0: float, x1: float, y1: float, rules: Rules,
                 inside) -> None:
        self.r = rules
        g = rules.grid
        self.x0, self.y0 = x0, y0
        self.nx = int(math.ceil((x1 - x0) / g)) + 1
        self.ny = int(math.ceil((y1 - y0) / g)) + 1
        xs = x0 + g * np.arange(self.nx)
        ys = y0 + g * np.arange(self.ny)
        self.X, self.Y = np.meshgrid(xs, ys)
        margin = g * 0.75
        self.t_inf = rules.clearance + rules.track / 2 + margin
        self.v_inf = rules.clearance + rules.via / 2 + margin
        # Blocking counts per layer: for tracks and for vias.
        self.ct = np.zeros((2, self.ny, self.nx), np.int16)
        self.cv = np.zeros((2, self.ny, self.nx), np.int16)
        self.own: dict[int, list] = {}
        self.novia = np.zeros((self.ny, self.nx), bool)
        d_edge = inside(self.X, self.Y)  # signed distance inside the outline (mm)
        self.edge_t = d_edge < rules.edge + rules.track / 2 + margin
        self.edge_v = d_edge < rules.edge + rules.via / 2 + margin
        self.tree: dict[int, set] = {}

    def _win(self, bx0, by0, bx1, by1, inf):
        g = self.r.grid
        i0 = max(0, int((bx0 - inf - self.x0) / g) - 1)
        i1 = min(self.nx, int((bx1 + inf - self.x0) / g) + 2)
        j0 = max(0, int((by0 - inf - self.y0) / g) - 1)
        j1 = min(self.ny, int((by1 + inf - self.y0) / g) + 2)
        return slice(j0, j1), slice(i0, i1)

    def add_shape(self, net: int, layers, dist, bbox, hole: bool = False) -> None:
        """dist(X, Y) -> distance from copper (<= 0 inside); bbox = x0, y0, x1, y1."""
        extra = self.r.hole_clearance - self.r.clearance if hole else 0.0
        for inf, cnt, kind in ((self.t_inf + extra, self.ct, "t"),
                               (self.v_inf + max(extra, 0.0), self.cv, "v")):
            sl = self._win(*bbox, inf)
            m = dist(self.X[sl], self.Y[sl]) < inf
            for layer in layers:
                cnt[layer][sl] += m
                if net > 0:
                    self.own.setdefault(net, []).append((kind, layer, sl, m))

    def pad_cells(self, dist, bbox) -> np.ndarray:
        sl = self._win(*bbox, 0.0)
        m = dist(self.X[sl], self.Y[sl]) < -0.02
        js, is_ = np.nonzero(m)
        return np.stack([js + sl[0].start, is_ + sl[1].start], axis=1)

    def blocked(self, net: int):
        ct = self.ct.copy()
        cv = self.cv.copy()
        for kind, layer, sl, m in self.own.get(net, []):
            (ct if kind == "t" else cv)[layer][sl] -= m
        bt = (ct > 0) | self.edge_t[None]
        bv = (cv > 0).any(axis=0) | self.edge_v | self.novia
        return bt, bv

    def route(self, net: int, sources, targets, goal_xy, bt, bv, via_cost=25.0):
        """sources/targets: lists of (layer, j, i). Returns the cell path or None."""
        g = self.r.grid
        gx = (goal_xy[0] - self.x0) / g
        gy = (goal_xy[1] - self.y0) / g
        tset = set(targets)
        best = {}
        heap = []
        for s in sources:
            if bt[s]:
                continue
            best[s] = 0.0
            h = math.hypot(s[2] - gx, s[1] - gy)
            heapq.heappush(heap, (h, 0.0, s, None, -1))
        came = {}
        moves = [(0, 1, 1.0), (1, 0, 1.0), (0, -1, 1.0), (-1, 0, 1.0),
                 (1, 1, 1.414), (1, -1, 1.414), (-1, 1, 1.414), (-1, -1, 1.414)]
        ny, nx = self.ny, self.nx
        expanded = 0
        while heap:
            f, cost, s, parent, d = heapq.heappop(heap)
            if s in came:
                continue
            came[s] = parent
            if s in tset:
                path = [s]
                while came[path[-1]] is not None:
                    path.append(came[path[-1]])
                return path[::-1]
            expanded += 1
            if expanded > 400000:
                return None
            layer, j, i = s
            for k, (dj, di, c) in enumerate(moves):
                jj, ii = j + dj, i + di
                if not (0 <= jj < ny and 0 <= ii < nx) or bt[layer, jj, ii]:
                    continue
                if dj and di and (bt[layer, j, ii] and bt[layer, jj, i]):
                    continue
                n = (layer, jj, ii)
                nc = cost + c + (0.3 if d not in (-1, k) else 0.0)
                if nc < best.get(n, 1e18):
                    best[n] = nc
                    heapq.heappush(heap, (nc + 1.05 * math.hypot(ii - gx, jj - gy), nc, n,
                                          s, k))
            if not bv[j, i]:
                n = (1 - layer, j, i)
                if not bt[n]:
                    nc = cost + via_cost
                    if nc < best.get(n, 1e18):
                        best[n] = nc
                        heapq.heappush(heap, (nc + math.hypot(i - gx, j - gy), nc, n, s, -1))
        return None

    def xy(self, j, i):
        return self.x0 + i * self.r.grid, self.y0 + j * self.r.grid


def seg_dist(ax, ay, bx, by, hw):
    def f(X, Y):
        dx, dy = bx - ax, by - ay
        L2 = dx * dx + dy * dy
        if L2 == 0:
            return np.hypot(X - ax, Y - ay) - hw
        t = np.clip(((X - ax) * dx + (Y - ay) * dy) / L2, 0, 1)
        return np.hypot(X - (ax + t * dx), Y - (ay + t * dy)) - hw
    return f


def rect_dist(cx, cy, hw, hh, ang_deg):
    a = math.radians(ang_deg)
    ca, sa = math.cos(a), math.sin(a)

    def f(X, Y):
        lx = (X - cx) * ca - (Y - cy) * sa
        ly = (X - cx) * sa + (Y - cy) * ca
        qx = np.abs(lx) - hw
        qy = np.abs(ly) - hh
        out = np.hypot(np.maximum(qx, 0), np.maximum(qy, 0))
        return np.where((qx < 0) & (qy < 0), np.maximum(qx, qy), out)
    return f


def circ_dist(cx, cy, r):
    return lambda X, Y: np.hypot(X - cx, Y - cy) - r


class BoardBuilder:
    def __init__(self, path: str, rules: Rules):
        self.path = path
        self.rules = rules
        self.board = pcbnew.NewBoard(path)
        self.board.SetCopperLayerCount(2)
        ds = self.board.GetDesignSettings()
        ds.m_MinClearance = MM(rules.clearance)
        ds.m_TrackMinWidth = MM(0.15)
        ds.m_ViasMinSize = MM(0.5)
        ds.m_MinThroughDrill = MM(0.3)
        ds.m_CopperEdgeClearance = MM(rules.edge)
        ds.m_HoleClearance = MM(rules.hole_clearance)
        ds.m_HoleToHoleMin = MM(0.5)
        ds.m_ViasMinAnnularWidth = MM(0.13)
        ds.SetBoardThickness(MM(1.6))
        nc = ds.m_NetSettings.GetDefaultNetclass()
        nc.SetClearance(MM(rules.clearance))
        nc.SetTrackWidth(MM(rules.track))
        nc.SetViaDiameter(MM(rules.via))
        nc.SetViaDrill(MM(rules.drill))
        self.nets: dict[str, pcbnew.NETINFO_ITEM] = {}
        self.fps: dict[str, pcbnew.FOOTPRINT] = {}
        self.outline: list = []

    def net(self, name: str):
        if name not in self.nets:
            ni = pcbnew.NETINFO_ITEM(self.board, name)
            self.board.Add(ni)
            self.nets[name] = ni
        return self.nets[name]

    def edge_line(self, a, b):
        s = pcbnew.PCB_SHAPE(self.board)
        s.SetShape(pcbnew.SHAPE_T_SEGMENT)
        s.SetStart(pcbnew.VECTOR2I(MM(a[0]), MM(a[1])))
        s.SetEnd(pcbnew.VECTOR2I(MM(b[0]), MM(b[1])))
        s.SetLayer(pcbnew.Edge_Cuts)
        s.SetWidth(MM(0.1))
        self.board.Add(s)

    def edge_arc(self, a, m, b):
        s = pcbnew.PCB_SHAPE(self.board)
        s.SetShape(pcbnew.SHAPE_T_ARC)
        s.SetArcGeometry(pcbnew.VECTOR2I(MM(a[0]), MM(a[1])),
                         pcbnew.VECTOR2I(MM(m[0]), MM(m[1])),
                         pcbnew.VECTOR2I(MM(b[0]), MM(b[1])))
        s.SetLayer(pcbnew.Edge_Cuts)
        s.SetWidth(MM(0.1))
        self.board.Add(s)

    def text(self, txt, x, y, layer=pcbnew.F_SilkS, size=1.0):
        t = pcbnew.PCB_TEXT(self.board)
        t.SetText(txt)
        t.SetPosition(pcbnew.VECTOR2I(MM(x), MM(y)))
        t.SetLayer(layer)
        t.SetTextSize(pcbnew.VECTOR2I(MM(size), MM(size)))
        t.SetTextThickness(MM(size * 0.15))
        self.board.Add(t)

    def place(self, ref, footprint, x, y, rot=0.0, value="", sym_uuid="", libdir=None,
              show_ref=True, attrs=None):
        lib, name = footprint.split(":")
        fp = pcbnew.FootprintLoad(libdir or f"{FPDIR}/{lib}.pretty", name)
        if fp is None:
            raise KeyError(footprint)
        fp.SetFPID(pcbnew.LIB_ID(lib, name))
        fp.SetReference(ref)
        fp.SetValue(value)
        fp.SetPosition(pcbnew.VECTOR2I(MM(x), MM(y)))
        fp.SetOrientationDegrees(rot)
        if sym_uuid:
            fp.SetPath(pcbnew.KIID_PATH("/" + sym_uuid))
        fp.Reference().SetVisible(show_ref)
        for item in fp.GraphicalItems():
            if item.GetLayer() == pcbnew.Edge_Cuts:   # e.g. jack outlines: not our board edge
                item.SetLayer(pcbnew.Dwgs_User)
        if attrs:
            fp.SetAttributes(fp.GetAttributes() | attrs)
        self.board.Add(fp)
        self.fps[ref] = fp
        return fp

    def assign(self, pin_nets: dict[tuple[str, str], str]) -> None:
        for fp in self.fps.values():
            for pad in fp.Pads():
                net = pin_nets.get((fp.GetReference(), pad.GetNumber()))
                if net:
                    pad.SetNet(self.net(net))

    def set_aux_origin(self, x, y):
        ds = self.board.GetDesignSettings()
        ds.SetAuxOrigin(pcbnew.VECTOR2I(MM(x), MM(y)))
        ds.SetGridOrigin(pcbnew.VECTOR2I(MM(x), MM(y)))

    # --- routing --------------------------------------------------------------------------
    def _pad_shape(self, pad):
        pos = pad.GetPosition()
        cx, cy = mm(pos.x), mm(pos.y)
        size = pad.GetSize(pcbnew.F_Cu)
        sx, sy = mm(size.x), mm(size.y)
        ang = pad.GetOrientation().AsDegrees()
        if pad.GetShape(pcbnew.F_Cu) == pcbnew.PAD_SHAPE_CIRCLE:
            f = circ_dist(cx, cy, sx / 2)
        else:
            f = rect_dist(cx, cy, sx / 2, sy / 2, -ang)
        r = math.hypot(sx, sy) / 2
        return f, (cx - r, cy - r, cx + r, cy + r)

    def _oval(self, pad):
        """Distance function of an oval pad (a stadium), or None for other shapes."""
        if pad.GetShape(pcbnew.F_Cu) != pcbnew.PAD_SHAPE_OVAL:
            return None
        pos = pad.GetPosition()
        cx, cy = mm(pos.x), mm(pos.y)
        size = pad.GetSize(pcbnew.F_Cu)
        sx, sy = mm(size.x), mm(size.y)
        a = math.radians(-pad.GetOrientation().AsDegrees())
        half = abs(sx - sy) / 2
        ux, uy = (math.cos(a), math.sin(a)) if sx >= sy else (-math.sin(a), math.cos(a))
        return seg_dist(cx - ux * half, cy - uy * half, cx + ux * half, cy + uy * half,
                        min(sx, sy) / 2)

    def route_all(self, order: list[str], inside, bbox, log=print, vias=None,
                  plane_nets=()) -> list[str]:
        """Route the nets in order. vias: {net: [(x, y)]} stitching vias to add and connect.
        plane_nets: nets carried by the zones: no tracks between their pads; each
        single-layer pad gets a via to the other layer (placed before any signal)."""
        r = self.rules
        rt = Router(*bbox, r, inside)
        self.router = rt
        pads_of: dict[int, list] = {}
        for name, pts in (vias or {}).items():
            netc = self.net(name).GetNetCode()
            for x, y in pts:
                v = pcbnew.PCB_VIA(self.board)
                v.SetPosition(pcbnew.VECTOR2I(MM(x), MM(y)))
                v.SetWidth(MM(r.via))
                v.SetDrill(MM(r.drill))
                v.SetNet(self.nets[name])
                self.board.Add(v)
                f = circ_dist(x, y, r.via / 2)
                bb = (x - r.via, y - r.via, x + r.via, y + r.via)
                rt.add_shape(netc, (0, 1), f, bb)
                j, i = int(round((y - rt.y0) / r.grid)), int(round((x - rt.x0) / r.grid))
                pads_of.setdefault(netc, []).append((v, [(0, j, i), (1, j, i)]))
        for fp in self.fps.values():
            for pad in fp.Pads():
                f, bb = self._pad_shape(pad)
                netc = pad.GetNetCode()
                attr = pad.GetAttribute()
                if attr in (pcbnew.PAD_ATTRIB_NPTH,):
                    d = mm(pad.GetDrillSize().x) / 2
                    pos = pad.GetPosition()
                    rt.add_shape(0, (0, 1), circ_dist(mm(pos.x), mm(pos.y), d), bb, hole=True)
                    continue
                layers = (0, 1) if attr == pcbnew.PAD_ATTRIB_PTH else \
                    ((0,) if pad.IsOnLayer(pcbnew.F_Cu) else (1,))
                rt.add_shape(netc, layers, f, bb)
                sl = rt._win(*bb, r.via / 2 + r.clearance)
                rt.novia[sl] |= f(rt.X[sl], rt.Y[sl]) < r.via / 2 + r.clearance
                if netc > 0:
                    # a route must end on copper: inside an oval pad, not in the corners of
                    # its bounding rectangle (the obstacle stays the rectangle)
                    cells = rt.pad_cells(self._oval(pad) or f, bb)
                    pads_of.setdefault(netc, []).append(
                        (pad, [(L, int(j), int(i)) for L in layers for j, i in cells]))
        failed = []
        plane_codes = {self.nets[n].GetNetCode() for n in plane_nets}
        for name in plane_nets:
            # Plane nets first: every single-layer pad gets its own short stub and a via to
            # the other layer's pour (through-hole pads touch both pours already). Done
            # before the signals, so these vias are reserved and the signals route around.
            netc = self.nets[name].GetNetCode()
            for pad, cells in pads_of.get(netc, []):
                if not hasattr(pad, "GetNumber") or \
                        pad.GetAttribute() == pcbnew.PAD_ATTRIB_PTH:
                    continue
                if not self._drop(netc, pad, cells, log):
                    failed.append(f"{name}: {pad.GetParentFootprint().GetReference()}."
                                  f"{pad.GetNumber()}")
                    log(f"  plane via FAILED {failed[-1]}")
        for name in order:
            netc = self.nets[name].GetNetCode()
            pads = pads_of.get(netc, [])
            if len(pads) < 2 or netc in plane_codes:
                continue
            tree = set(pads[0][1])
            todo = pads[1:]
            while todo:
                # nearest pad to the tree (by centre) first
                tx = np.array([rt.xy(j, i) for (_, j, i) in list(tree)[:2000]])

                def dist(p, tx=tx):
                    pos = p[0].GetPosition()
                    return float(np.min(np.hypot(tx[:, 0] - mm(pos.x), tx[:, 1] - mm(pos.y))))
                todo.sort(key=dist)
                pad, cells = todo.pop(0)
                bt, bv = rt.blocked(netc)
                pos = pad.GetPosition()
                path = rt.route(netc, list(tree), cells, (mm(pos.x), mm(pos.y)), bt, bv)
                if path is None:
                    where = (f"{pad.GetParentFootprint().GetReference()}.{pad.GetNumber()}"
                             if hasattr(pad, "GetNumber") else "via")
                    failed.append(f"{name}: {where}")
                    log(f"  route FAILED {failed[-1]}")
                    tree |= set(cells)
                    continue
                self._emit(netc, path)
                tree |= set(cells) | set(path)
        return failed

    def _drop(self, netc, pad, cells, log, reach: float = 3.0) -> bool:
        """A via next to a single-layer pad (stub on the pad's layer): the other layer's pour
        connects it. Via sites towards the footprint's centre first (under an IC or a
        connector body, leaving the pad's outer side to the signals), then any side."""
        rt = self.router
        bt, bv = rt.blocked(netc)
        layer = cells[0][0]
        src = [c for c in cells if c[0] == layer]
        j0 = int(np.mean([c[1] for c in src]))
        i0 = int(np.mean([c[2] for c in src]))
        k = int(reach / self.rules.grid)
        js = slice(max(0, j0 - k), min(rt.ny, j0 + k + 1))
        is_ = slice(max(0, i0 - k), min(rt.nx, i0 + k + 1))
        jj, ii = np.nonzero(~bt[1 - layer][js, is_])
        jj, ii = jj + js.start, ii + is_.start
        pos = pad.GetPosition()
        px, py = mm(pos.x), mm(pos.y)
        fc = pad.GetParentFootprint().GetPosition()
        cx, cy = mm(fc.x) - px, mm(fc.y) - py
        X = rt.x0 + ii * self.rules.grid - px
        Y = rt.y0 + jj * self.rules.grid - py
        inward = (X * cx + Y * cy) > 0.0
        for sel in (inward, np.ones_like(inward)):
            if math.hypot(cx, cy) < 0.1 and sel is inward:
                continue
            tg = [(1 - layer, int(j), int(i)) for j, i in zip(jj[sel], ii[sel], strict=True)]
            path = rt.route(netc, src, tg, (px, py), bt, bv, via_cost=2.0) if tg else None
            if path is not None:
                self._emit(netc, path)
                return True
        return False

    def _emit(self, netc, path):
        rt = self.router
        r = self.rules
        net = self.board.FindNet(netc)
        # split into straight runs per layer, vias at layer changes
        pts = [path[0]]
        for a, b, c in zip(path, path[1:], path[2:], strict=False):
            if a[0] != b[0] or b[0] != c[0]:
                pts.append(b)
                continue
            if (b[1] - a[1], b[2] - a[2]) != (c[1] - b[1], c[2] - b[2]):
                pts.append(b)
        pts.append(path[-1])
        for a, b in zip(pts, pts[1:], strict=False):
            ax, ay = rt.xy(a[1], a[2])
            bx, by = rt.xy(b[1], b[2])
            if a[0] != b[0]:
                v = pcbnew.PCB_VIA(self.board)
                v.SetPosition(pcbnew.VECTOR2I(MM(ax), MM(ay)))
                v.SetWidth(MM(r.via))
                v.SetDrill(MM(r.drill))
                v.SetNet(net)
                self.board.Add(v)
                rt.add_shape(netc, (0, 1), circ_dist(ax, ay, r.via / 2),
                             (ax - r.via, ay - r.via, ax + r.via, ay + r.via))
                sl = rt._win(ax, ay, ax, ay, 0.5 + r.via)
                rt.novia[sl] |= np.hypot(rt.X[sl] - ax, rt.Y[sl] - ay) < r.via + 0.5
                continue
            t = pcbnew.PCB_TRACK(self.board)
            t.SetStart(pcbnew.VECTOR2I(MM(ax), MM(ay)))
            t.SetEnd(pcbnew.VECTOR2I(MM(bx), MM(by)))
            t.SetWidth(MM(r.track))
            t.SetLayer(pcbnew.F_Cu if a[0] == 0 else pcbnew.B_Cu)
            t.SetNet(net)
            self.board.Add(t)
            hw = r.track / 2
            rt.add_shape(netc, (a[0],), seg_dist(ax, ay, bx, by, hw),
                         (min(ax, bx) - hw, min(ay, by) - hw, max(ax, bx) + hw, max(ay, by) + hw))

    def zone(self, net: str, layer, outline_pts, clearance=0.25, min_width=0.2, holes=()):
        """holes: (x, y, r) circles cut out of the zone (NPTH keep-back)."""
        z = pcbnew.ZONE(self.board)
        z.SetLayer(layer)
        z.SetNet(self.net(net))
        chain = pcbnew.SHAPE_LINE_CHAIN()
        for x, y in outline_pts:
            chain.Append(MM(x), MM(y))
        chain.SetClosed(True)
        z.Outline().AddOutline(chain)
        holes = list(holes)
        for fp in self.fps.values():
            for pad in fp.Pads():
                if pad.GetAttribute() == pcbnew.PAD_ATTRIB_NPTH:
                    pos = pad.GetPosition()
                    holes.append((mm(pos.x), mm(pos.y),
                                  mm(max(pad.GetDrillSize().x, pad.GetDrillSize().y)) / 2 + 0.35))
        for hx, hy, hr in holes:
            hc = pcbnew.SHAPE_LINE_CHAIN()
            for k in range(32):
                a = 2 * math.pi * k / 32
                hc.Append(MM(hx + hr * math.cos(a)), MM(hy + hr * math.sin(a)))
            hc.SetClosed(True)
            z.Outline().AddHole(hc)
        z.SetLocalClearance(MM(clearance))
        z.SetMinThickness(MM(min_width))
        z.SetPadConnection(pcbnew.ZONE_CONNECTION_FULL)
        z.SetIslandRemovalMode(pcbnew.ISLAND_REMOVAL_MODE_ALWAYS)
        self.board.Add(z)
        return z

    def save(self) -> int:
        """Fill the zones, save; returns the number of unconnected items after the fill."""
        filler = pcbnew.ZONE_FILLER(self.board)
        filler.Fill(self.board.Zones())
        self.board.BuildConnectivity()
        unconnected = self.board.GetConnectivity().GetUnconnectedCount(False)
        pcbnew.SaveBoard(self.path, self.board)
        return unconnected


def polygon_inside(poly):
    """Signed distance function: > 0 inside the closed polygon (list of (x, y)), in mm."""
    P = np.asarray(poly, float)
    A = P
    B = np.roll(P, -1, axis=0)

    def f(X, Y):
        inside = np.zeros(X.shape, bool)
        dmin = np.full(X.shape, np.inf)
        for (ax, ay), (bx, by) in zip(A, B, strict=False):
            cond = (ay > Y) != (by > Y)
            with np.errstate(divide="ignore", invalid="ignore"):
                xint = ax + (Y - ay) * (bx - ax) / (by - ay)
            inside ^= cond & (X < xint)
            dmin = np.minimum(dmin, seg_dist(ax, ay, bx, by, 0.0)(X, Y))
        return np.where(inside, dmin, -dmin)
    return f


def stitch(bb: BoardBuilder, net: str, pitch: float = 4.0) -> int:
    """GND stitching vias on a grid wherever one fits (joins the F.Cu and B.Cu pours)."""
    rt = bb.router
    r = bb.rules
    netc = bb.nets[net].GetNetCode()
    bt, bv = rt.blocked(netc)
    step = int(pitch / r.grid)
    n = 0
    for j in range(step // 2, rt.ny, step):
        for i in range(step // 2, rt.nx, step):
            # a via needs room for the pour around it: keep 0.5 mm more
            k = int(0.5 / r.grid)
            win = bv[max(0, j - k):j + k + 1, max(0, i - k):i + k + 1]
            if win.size and not win.any() and not bt[:, j, i].any():
                x, y = rt.xy(j, i)
                v = pcbnew.PCB_VIA(bb.board)
                v.SetPosition(pcbnew.VECTOR2I(MM(x), MM(y)))
                v.SetWidth(MM(r.via))
                v.SetDrill(MM(r.drill))
                v.SetNet(bb.nets[net])
                bb.board.Add(v)
                n += 1
    return n



def join_fragments(board, net: str, rules: Rules, step: float = 0.25) -> int:
    """After a fill: group the pour fragments of ``net`` on both layers into connected sets
    (a via or through-hole pad joins the fragments it sits in on both layers, a track joins
    the fragments of its two ends) and add a via wherever one fits in a fragment of a
    smaller set over a fragment of the largest set, until one set is left. Refills; returns
    the vias added."""
    netc = board.FindNet(net).GetNetCode()
    zones = {z.GetLayer(): z for z in board.Zones() if z.GetNetCode() == netc}
    layers = (pcbnew.F_Cu, pcbnew.B_Cu)
    added = 0
    for _ in range(20):
        frags = {L: zones[L].GetFilledPolysList(L) for L in layers}
        sets = _fragment_sets(board, netc, frags)
        if len(sets) <= 1:
            break
        area = {root: sum(abs(frags[L].Outline(i).Area()) for L, i in ks)
                for root, ks in sets.items()}
        main = max(area, key=area.get)
        if not _via_into(board, netc, frags, [k for r, ks in sets.items() if r != main
                                              for k in ks], set(sets[main]), rules, step):
            break
        added += 1
        pcbnew.ZONE_FILLER(board).Fill(board.Zones())
    return added


def _fragment_sets(board, netc: int, frags: dict) -> dict:
    """Pour fragments ((layer, index)) grouped by what connects them: root -> members."""
    layers = (pcbnew.F_Cu, pcbnew.B_Cu)
    parent: dict = {}

    def find(k):
        parent.setdefault(k, k)
        while parent[k] != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    def where(L, pt):
        ps = frags[L]
        return [(L, i) for i in range(ps.OutlineCount()) if ps.Outline(i).PointInside(pt)]

    def union(items):
        items = [find(k) for k in items]
        for k in items[1:]:
            parent[k] = items[0]
    for L in layers:
        for i in range(frags[L].OutlineCount()):
            find((L, i))
    for t in board.GetTracks():
        if t.GetNetCode() != netc:
            continue
        if t.GetClass() == "PCB_VIA":
            union(where(pcbnew.F_Cu, t.GetPosition()) + where(pcbnew.B_Cu, t.GetPosition()))
        else:
            union(where(t.GetLayer(), t.GetStart()) + where(t.GetLayer(), t.GetEnd()))
    for fp in board.GetFootprints():
        for pad in fp.Pads():
            if pad.GetNetCode() == netc:
                union([k for L in layers if pad.IsOnLayer(L) for k in where(L, pad.GetPosition())])
    sets: dict = {}
    for k in list(parent):
        sets.setdefault(find(k), []).append(k)
    return sets


def _via_into(board, netc, frags, small, main, rules: Rules, step: float) -> bool:
    """One via in a fragment of ``small`` over a fragment of ``main`` (other layer)."""
    keep = rules.via / 2 + rules.clearance + 0.05
    others = []
    for t in board.GetTracks():
        if t.GetNetCode() == netc and t.GetClass() != "PCB_VIA":
            continue
        if t.GetClass() == "PCB_VIA":
            others.append(("c", mm(t.GetPosition().x), mm(t.GetPosition().y), rules.via / 2))
        else:
            others.append(("s", mm(t.GetStart().x), mm(t.GetStart().y), mm(t.GetEnd().x),
                           mm(t.GetEnd().y), mm(t.GetWidth()) / 2))
    pads = []
    for fp in board.GetFootprints():
        for pad in fp.Pads():
            bb = pad.GetBoundingBox()
            pads.append((mm(bb.GetX()), mm(bb.GetY()), mm(bb.GetRight()), mm(bb.GetBottom()),
                         pad.GetNetCode() == netc and pad.GetAttribute() !=
                         pcbnew.PAD_ATTRIB_NPTH, pad.HasHole()))

    def free(x, y) -> bool:
        for x0, y0, x1, y1, same, hole in pads:
            m = keep + (0.1 if hole else 0.0)
            if x0 - m < x < x1 + m and y0 - m < y < y1 + m and not (same and not hole):
                return False
        for o in others:
            if o[0] == "c":
                if math.hypot(x - o[1], y - o[2]) < keep + o[3] + 0.1:
                    return False
            elif float(seg_dist(o[1], o[2], o[3], o[4], o[5])(np.array(x), np.array(y))) < keep:
                return False
        return True
    for L, i in small:
        o = frags[L].Outline(i)
        other = pcbnew.B_Cu if L == pcbnew.F_Cu else pcbnew.F_Cu
        bb = o.BBox()
        x0, y0 = mm(bb.GetX()), mm(bb.GetY())
        x1, y1 = x0 + mm(bb.GetWidth()), y0 + mm(bb.GetHeight())
        y = y0
        while y <= y1:
            x = x0
            while x <= x1:
                p = pcbnew.VECTOR2I(MM(x), MM(y))
                # the via's whole pad inside both fragments: test its rim
                rim = [pcbnew.VECTOR2I(MM(x + rules.via / 2 * math.cos(a)),
                                       MM(y + rules.via / 2 * math.sin(a)))
                       for a in np.linspace(0, 2 * math.pi, 8, endpoint=False)]
                if o.PointInside(p) and all(o.PointInside(q) for q in rim):
                    tgt = [k for k in main if k[0] == other]
                    ok = [k for k in tgt if frags[other].Outline(k[1]).PointInside(p)
                          and all(frags[other].Outline(k[1]).PointInside(q) for q in rim)]
                    if ok and free(x, y):
                        v = pcbnew.PCB_VIA(board)
                        v.SetPosition(p)
                        v.SetWidth(MM(rules.via))
                        v.SetDrill(MM(rules.drill))
                        v.SetNet(board.FindNet(netc))
                        board.Add(v)
                        return True
                x += step
            y += step
    return False
