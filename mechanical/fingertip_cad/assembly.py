"""The fingertip as a CadQuery assembly (named, coloured parts in their mounted places)."""
from __future__ import annotations

import cadquery as cq

from . import bought
from .build import Parts

COLOURS = {
    "pcb": (0.1, 0.45, 0.15, 1.0),
    "base": (0.32, 0.33, 0.38, 1.0),
    "prism": (0.95, 0.95, 0.92, 1.0),
    "gauge": (0.85, 0.55, 0.1, 1.0),
    "cap": (0.2, 0.4, 0.8, 1.0),
    "screw": (0.6, 0.6, 0.62, 1.0),
    "piezo": (0.8, 0.65, 0.3, 1.0),
    "skin": (0.9, 0.9, 0.85, 0.45),
    "mold_a": (0.85, 0.3, 0.25, 1.0),
    "mold_b": (0.95, 0.55, 0.2, 1.0),
}


def _colour(name: str) -> cq.Color:
    return cq.Color(*COLOURS[name])


def fingertip_assembly(parts: Parts) -> cq.Assembly:
    """Base, prism, gauges, cap, screw, piezo, skin and the PCB outline."""
    asm = cq.Assembly(name="fingertip")
    for name in ("pcb", "base", "prism", "cap", "screw", "piezo", "skin"):
        asm.add(getattr(parts, name), name=name, color=_colour(name))
    for ch in range(4):
        asm.add(bought.gauge_backing(parts.dims, ch), name=f"gauge{ch}", color=_colour("gauge"))
    return asm


def mold_assembly(parts: Parts) -> cq.Assembly:
    """The closed mold around the fingertip, ready to pour."""
    asm = fingertip_assembly(parts)
    asm.name = "fingertip_in_mold"
    asm.add(parts.mold_a, name="mold_a", color=_colour("mold_a"))
    asm.add(parts.mold_b, name="mold_b", color=_colour("mold_b"))
    return asm
