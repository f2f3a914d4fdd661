"""Build every part from one set of dimensions, with per-part progress in the log."""
from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass

import cadquery as cq

from . import base_prism, bought, cap, mold, skin
from .dims import Dims

log = logging.getLogger(__name__)

# Printed and cast parts (exported as STL + STEP), with their material.
MATERIALS = {
    "base": "TPU 95A",
    "prism": "PLA",
    "cap": "PLA",
    "skin": "Mold Star 20T silicone",
    "mold_a": "PLA",
    "mold_b": "PLA",
}


@dataclass(frozen=True)
class Parts:
    dims: Dims
    base: cq.Solid
    prism: cq.Solid
    cap: cq.Solid
    skin: cq.Solid
    mold_a: cq.Solid
    mold_b: cq.Solid
    piezo: cq.Solid
    screw: cq.Shape
    pcb: cq.Shape

    def made(self) -> dict[str, cq.Solid]:
        """The parts we make (print or cast), by name."""
        return {name: getattr(self, name) for name in MATERIALS}


def build(d: Dims, progress: Callable[[str, int, int], None] | None = None) -> Parts:
    """Build all parts; ``progress(name, i, n)`` is called before each one."""
    steps: list[tuple[str, Callable[[], object]]] = [
        ("base", lambda: base_prism.base(d)),
        ("prism", lambda: base_prism.prism(d)),
        ("cap", lambda: cap.cap(d)),
        ("skin", lambda: skin.skin(d)),
        ("mold", lambda: mold.mold_halves(d)),
        ("piezo", lambda: skin.piezo_disc(d)),
        ("screw", lambda: bought.screw(d)),
        ("pcb", lambda: bought.pcb(d)),
    ]
    out: dict[str, object] = {}
    for i, (name, make) in enumerate(steps):
        if progress:
            progress(name, i, len(steps))
        t0 = time.perf_counter()
        out[name] = make()
        log.info("built %-6s in %.2f s", name, time.perf_counter() - t0)
    mold_a, mold_b = out.pop("mold")  # type: ignore[misc]
    return Parts(dims=d, mold_a=mold_a, mold_b=mold_b, **out)  # type: ignore[arg-type]
