"""Checks of exported meshes (trimesh) and of the solids themselves (OpenCascade), pure
functions that return numbers, so that tests and users can both call them."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh


@dataclass(frozen=True)
class MeshReport:
    watertight: bool
    winding_consistent: bool
    volume: float
    bounds: np.ndarray          # [[xmin, ymin, zmin], [xmax, ymax, zmax]]

    @property
    def ok(self) -> bool:
        return self.watertight and self.winding_consistent and self.volume > 0


def load_mesh(path: str | Path) -> trimesh.Trimesh:
    """Load an STL with validation (merges vertices, drops the zero-area triangles that
    tessellated fillets leave and that otherwise look like holes)."""
    return trimesh.load(str(path), force="mesh", process=True, validate=True)


def mesh_report(mesh: trimesh.Trimesh) -> MeshReport:
    return MeshReport(bool(mesh.is_watertight), bool(mesh.is_winding_consistent),
                      float(mesh.volume), np.asarray(mesh.bounds))


def wall_thickness(mesh: trimesh.Trimesh, samples: int = 4000, seed: int = 0,
                   edge_margin: float = 0.02) -> tuple[float, np.ndarray]:
    """Smallest local wall thickness found by casting rays inward from surface samples.

    Each ray starts just inside the surface along the inward normal and the distance to the
    first surface it meets is the wall there. Samples within ``edge_margin`` of a triangle
    edge of a different face plane are skipped: a ray from a corner meets the neighbouring
    face at once and would report a wall that is not there. Returns (thickness, point).
    """
    rng = np.random.default_rng(seed)
    # Sample by area, then keep points away from sharp edges (feature edges of the mesh).
    points, face_idx = trimesh.sample.sample_surface(mesh, samples, seed=int(rng.integers(1 << 31)))
    normals = mesh.face_normals[face_idx]
    keep = _away_from_feature_edges(mesh, points, edge_margin)
    points, normals = points[keep], normals[keep]
    eps = 1e-4
    origins = points - normals * eps
    locs, ray_idx, _ = mesh.ray.intersects_location(origins, -normals, multiple_hits=False)
    if len(ray_idx) == 0:
        return float("inf"), np.zeros(3)
    dist = np.linalg.norm(locs - origins[ray_idx], axis=1) + eps
    i = int(np.argmin(dist))
    return float(dist[i]), points[ray_idx[i]]


def _away_from_feature_edges(mesh: trimesh.Trimesh, points: np.ndarray, margin: float
                             ) -> np.ndarray:
    """Mask of points farther than ``margin`` from every sharp edge (> 10 degrees)."""
    angles = mesh.face_adjacency_angles
    edges = mesh.face_adjacency_edges[angles > np.radians(10)]
    if len(edges) == 0:
        return np.ones(len(points), bool)
    a, b = mesh.vertices[edges[:, 0]], mesh.vertices[edges[:, 1]]
    keep = np.ones(len(points), bool)
    ab = b - a
    ab2 = np.maximum((ab * ab).sum(1), 1e-18)
    for start in range(0, len(points), 256):
        p = points[start:start + 256, None, :]
        t = np.clip(((p - a) * ab).sum(2) / ab2, 0, 1)
        d = np.linalg.norm(p - (a + t[..., None] * ab), axis=2).min(1)
        keep[start:start + 256] = d > margin
    return keep


def first_hit_x(mesh: trimesh.Trimesh, y: float, z: float, x_from: float = 1e3) -> float:
    """x of the first surface met by a ray from +x far away towards -x, at (y, z)."""
    locs, _, _ = mesh.ray.intersects_location([[x_from, y, z]], [[-1.0, 0.0, 0.0]],
                                              multiple_hits=True)
    if len(locs) == 0:
        return float("-inf")
    return float(locs[:, 0].max())


# --- BRep (OpenCascade through CadQuery) ---------------------------------------------------

def common_volume(a, b) -> float:
    """Volume shared by two solids (0 when they only touch)."""
    inter = a.intersect(b)
    return float(sum(s.Volume() for s in inter.Solids()))


def distance(a, b) -> float:
    """Smallest distance between two shapes (BRepExtrema)."""
    return float(a.distance(b))


def point_distance(shape, xyz) -> float:
    import cadquery as cq

    return float(shape.distance(cq.Vertex.makeVertex(*xyz)))


def inside(solid, xyz, tolerance: float = 1e-6) -> bool:
    import cadquery as cq

    return bool(solid.isInside(cq.Vector(*xyz), tolerance))


# --- the fingertip PCB against the base ------------------------------------------------------

def rounded_triangle_area(inradius: float, corner_radius: float) -> float:
    a = inradius - corner_radius
    return 3 * 3 ** 0.5 * a * a + 6 * 3 ** 0.5 * a * corner_radius \
        + 3.141592653589793 * corner_radius ** 2


def pcb_fit_problems(board, dims, base) -> list[str]:
    """Why the board (``kicad.Board``) does not fit the base solid, or [] when it does: its
    outline follows the base's underside (0.05 mm), its M2 holes sit on the base's pilots with
    the contract's clearance diameter, and its top-side pads and part bodies (F.Fab) lie in
    the pocket (or beyond the base's edge, where the cable leaves)."""
    from .kicad import polygon_area

    m = dims.p.mount
    problems = []
    if board.centre is None:
        return ["no board origin: neither an aux origin nor M2 mounting holes"]
    outline = board.to_frame(board.outline)
    if len(outline) < 10:
        return ["the board has no Edge.Cuts outline"]
    area = polygon_area(outline)
    want = rounded_triangle_area(dims.base_inradius, m.base_corner_radius_mm)
    if abs(area - want) > 0.005 * want:
        problems.append(f"board area {area:.2f} mm^2, the base's underside {want:.2f} mm^2")
    z = m.pocket_depth_mm + 0.3           # above the pocket: the base's full section
    cx = sum(p[0] for p in outline) / len(outline)
    cy = sum(p[1] for p in outline) / len(outline)
    bad = 0
    for x, y in outline[::5]:
        dx, dy = cx - x, cy - y
        n = (dx * dx + dy * dy) ** 0.5 or 1.0
        if not inside(base, (x + 0.05 * dx / n, y + 0.05 * dy / n, z)) \
                or inside(base, (x - 0.05 * dx / n, y - 0.05 * dy / n, z)):
            bad += 1
    if bad:
        problems.append(f"{bad} outline points are more than 0.05 mm off the base's edge")
    holes = [(x - board.centre[0], -(y - board.centre[1]), dia) for x, y, dia in board.holes]
    for hx, hy in m.mount_holes_xy_mm():
        near = [h for h in holes if ((h[0] - hx) ** 2 + (h[1] - hy) ** 2) ** 0.5 < 0.05]
        if len(near) != 1:
            problems.append(f"no board hole at ({hx:.2f}, {hy:.2f})")
            continue
        if abs(near[0][2] - m.mount_clearance_diameter_mm) > 0.01:
            problems.append(f"hole at ({hx:.2f}, {hy:.2f}) is {near[0][2]} mm, "
                            f"not {m.mount_clearance_diameter_mm}")
        r = m.mount_pilot_diameter_mm / 2
        if inside(base, (hx, hy, 1.0)) or not inside(base, (hx + r + 0.1, hy, 1.0)):
            problems.append(f"the base's pilot hole is not under ({hx:.2f}, {hy:.2f})")
    if len(holes) != len(m.mount_hole_angles_deg):
        problems.append(f"{len(holes)} M2-size holes on the board, "
                        f"{len(m.mount_hole_angles_deg)} in [mount]")
    z_part = m.pocket_depth_mm - 0.05
    clash = [(round(x, 2), round(y, 2)) for x, y in board.to_frame(board.top_points)
             if inside(base, (x, y, z_part))]
    if clash:
        problems.append(f"{len(clash)} top-side pad/body points hit the base outside the "
                        f"pocket, e.g. {clash[:4]}")
    return problems
