"""Export STL and STEP per part, the assemblies as STEP, and PNG renders, with progress."""
from __future__ import annotations

import json
import logging
import time
from collections.abc import Callable
from pathlib import Path

import cadquery as cq

from .assembly import fingertip_assembly, mold_assembly
from .build import MATERIALS, Parts, build
from .dims import Dims

log = logging.getLogger(__name__)

# Chord tolerance of the STL meshes (mm): fine enough that the mesh checks hold to 0.01 mm
# on the flat faces, coarse enough to keep each file small.
STL_TOLERANCE_MM = 0.01
STL_ANGULAR_TOLERANCE = 0.1


def export_all(d: Dims, out: Path, *, renders: bool = True,
               progress: Callable[[str, int, int], None] | None = None,
               parts: Parts | None = None) -> dict:
    """Build (unless ``parts`` is given) and write everything to ``out``; returns a manifest
    (also written as ``manifest.json``) with the files, volumes and the key dimensions.
    ``progress(label, i, n)`` is called before each file (the CLI prints a line each)."""
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    parts = parts or build(d)
    made = parts.made()
    jobs: list[tuple[str, Callable[[], None]]] = []
    for name, solid in made.items():
        jobs.append((f"{name}.stl", _stl(solid, out / f"{name}.stl")))
        jobs.append((f"{name}.step", _step(solid, out / f"{name}.step")))
    jobs.append(("fingertip_assembly.step",
                 lambda: fingertip_assembly(parts).export(str(out / "fingertip_assembly.step"))))
    jobs.append(("mold_assembly.step",
                 lambda: mold_assembly(parts).export(str(out / "mold_assembly.step"))))
    if renders:
        from .render import render_fingertip, render_mold  # matplotlib only when asked
        jobs.append(("cad_fingertip.png", lambda: render_fingertip(out, out / "cad_fingertip.png")))
        jobs.append(("cad_mold.png", lambda: render_mold(out, out / "cad_mold.png")))
    for i, (label, job) in enumerate(jobs):
        if progress:
            progress(label, i, len(jobs))
        log.info("[%2d/%d] %s", i + 1, len(jobs), label)
        job()
    manifest = {
        "parts": {name: {"material": MATERIALS[name], "volume_mm3": round(s.Volume(), 3),
                         "stl": f"{name}.stl", "step": f"{name}.step"}
                  for name, s in made.items()},
        "assemblies": ["fingertip_assembly.step", "mold_assembly.step"],
        "summary": d.summary,
    }
    (out / "manifest.json").write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")
    log.info("exported %d files to %s in %.1f s", len(jobs) + 1, out, time.perf_counter() - t0)
    return manifest


def _stl(solid: cq.Shape, path: Path) -> Callable[[], None]:
    return lambda: cq.exporters.export(solid, str(path), "STL", tolerance=STL_TOLERANCE_MM,
                                       angularTolerance=STL_ANGULAR_TOLERANCE)


def _step(solid: cq.Shape, path: Path) -> Callable[[], None]:
    return lambda: cq.exporters.export(solid, str(path), "STEP")
