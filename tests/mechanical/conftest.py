"""Build and export the fingertip once per session and per parameter variant.

Variants: the shipped parameters, the issue's 22 mm fingertip (only outer_width_mm changed),
and a 22 x 30 mm one with a longer prism (heights change too). Every check in this folder runs
on each, so a parameter change that breaks a part fails here.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import pytest

from fingertip_cad import Dims, load_params
from fingertip_cad.build import Parts, build
from fingertip_cad.checks import load_mesh
from fingertip_cad.export import export_all

VARIANTS = {
    "shipped": {},
    "w22": {"geometry.outer_width_mm": 22.0},
    "w22h30": {"geometry.outer_width_mm": 22.0, "geometry.outer_height_mm": 30.0,
               "geometry.prism_length_mm": 20.0, "geometry.nail_tip_z_mm": 22.0},
}


@dataclass
class Built:
    name: str
    dims: Dims
    parts: Parts
    out: Path
    meshes: dict = field(default_factory=dict)

    def mesh(self, name: str):
        if name not in self.meshes:
            self.meshes[name] = load_mesh(self.out / f"{name}.stl")
        return self.meshes[name]


_CACHE: dict[str, Built] = {}


def built_variant(name: str, tmp_path_factory) -> Built:
    if name not in _CACHE:
        d = Dims(load_params(overrides=VARIANTS[name]))
        parts = build(d)
        out = tmp_path_factory.mktemp(f"cad_{name}")
        export_all(d, out, renders=(name == "shipped"), progress=None, parts=parts)
        _CACHE[name] = Built(name, d, parts, out)
    return _CACHE[name]


@pytest.fixture(scope="session", params=list(VARIANTS))
def cad(request, tmp_path_factory) -> Built:
    return built_variant(request.param, tmp_path_factory)


@pytest.fixture(scope="session")
def shipped(tmp_path_factory) -> Built:
    return built_variant("shipped", tmp_path_factory)
