"""PNG renders of the exported STL meshes (matplotlib, no display needed)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import trimesh  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

from .assembly import COLOURS  # noqa: E402

LIGHT = np.array([0.4, -0.5, 0.75]) / np.linalg.norm([0.4, -0.5, 0.75])


def _draw(ax, mesh: trimesh.Trimesh, colour, offset=(0.0, 0.0, 0.0), alpha=None) -> None:
    tris = mesh.triangles + np.asarray(offset)
    shade = 0.45 + 0.55 * np.clip(mesh.face_normals @ LIGHT, 0, 1)
    rgba = np.tile(np.asarray(colour, float), (len(tris), 1))
    rgba[:, :3] *= shade[:, None]
    if alpha is not None:
        rgba[:, 3] = alpha
    ax.add_collection3d(Poly3DCollection(tris, facecolors=rgba, edgecolors="none"))


def _frame(ax, lo, hi, elev: float, azim: float, title: str) -> None:
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(hi - lo)
    ax.view_init(elev=elev, azim=azim)
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("x (mm)", fontsize=7)
    ax.set_ylabel("y (mm)", fontsize=7)
    ax.set_zlabel("z (mm)", fontsize=7)
    ax.tick_params(labelsize=6)


def _load(folder: Path, name: str) -> trimesh.Trimesh:
    return trimesh.load(folder / f"{name}.stl", force="mesh")


def render_fingertip(folder: Path, png: Path) -> None:
    """Exploded view, assembled view (translucent skin) and the base from below."""
    m = {n: _load(folder, n) for n in ("base", "prism", "cap", "skin")}
    fig = plt.figure(figsize=(12, 5.2), dpi=90)
    ax = fig.add_subplot(1, 3, 1, projection="3d")
    lift = {"base": 0, "prism": 0, "cap": 20, "skin": 44}
    for n, mesh in m.items():
        _draw(ax, mesh, COLOURS[n], (0, 0, lift[n]), alpha=0.55 if n == "skin" else None)
    _frame(ax, (-11, -11, 0), (11, 11, 72), 12, -60, "exploded: base + prism, cap, skin")
    ax = fig.add_subplot(1, 3, 2, projection="3d")
    for n in ("base", "prism", "cap"):
        _draw(ax, m[n], COLOURS[n])
    _draw(ax, m["skin"], COLOURS["skin"], alpha=0.25)
    _frame(ax, (-11, -11, 0), (11, 11, 28), 22, -50, "assembled (skin translucent)")
    ax = fig.add_subplot(1, 3, 3, projection="3d")
    _draw(ax, m["base"], COLOURS["base"])
    _draw(ax, m["prism"], COLOURS["prism"])
    _frame(ax, (-10, -10, 0), (10, 10, 8), -55, -100, "base from below: pocket, M2 pilots,\n"
           "FFC exit at -y, wire holes")
    fig.tight_layout()
    fig.savefig(png)
    plt.close(fig)


def render_mold(folder: Path, png: Path) -> None:
    """The -y half seen from the parting plane (cavity, nail pocket, pins, half channels),
    and the closed mold around the fingertip seen from +x (pour and vents)."""
    m = {n: _load(folder, n) for n in ("mold_a", "mold_b", "cap", "skin", "base", "prism")}
    fig = plt.figure(figsize=(11, 5.2), dpi=90)
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    _draw(ax, m["mold_a"], COLOURS["mold_a"])
    _frame(ax, (-16, -16, 5), (17, 3, 33), 15, 70, "-y half, parting face: cavity, nail "
           "pocket, 3 pins, pour + vents")
    ax = fig.add_subplot(1, 2, 2, projection="3d")
    for n in ("base", "prism"):
        _draw(ax, m[n], COLOURS[n])
    _draw(ax, m["mold_a"], COLOURS["mold_a"])
    _draw(ax, m["mold_b"], COLOURS["mold_b"])
    _frame(ax, (-16, -16, 0), (17, 16, 33), 20, 25, "closed on the fingertip, seen from +x "
           "(fill lying on the -x side)")
    fig.tight_layout()
    fig.savefig(png)
    plt.close(fig)
