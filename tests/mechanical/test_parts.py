"""Every exported part: a valid, watertight solid whose size is what the parameters say."""
from __future__ import annotations

import math

import cadquery as cq
import pytest

from fingertip_cad.build import MATERIALS
from fingertip_cad.checks import mesh_report

TOL = 0.01   # mm


def expected_bounds(b) -> dict[str, tuple[tuple[float, ...], tuple[float, ...]]]:
    """Bounding boxes straight from the parameters (not from the CAD's own Dims)."""
    p = b.dims.p
    g, m, c = p.geometry, p.mount, p.cad
    inr, rc = m.base_side_mm / (2 * math.sqrt(3)), m.base_corner_radius_mm
    half_w, half_cap = g.outer_width_mm / 2, g.outer_width_mm / 2 - g.skin_mm
    base_top = g.base_height_mm
    cap_z = (base_top + c.cap_base_clearance_mm, base_top + g.prism_length_mm + g.cap_roof_mm)
    mold_x = (-half_w - c.mold_wall_mm, half_w + g.nail_proud_mm + c.mold_wall_mm)
    mold_y = half_w + c.mold_wall_mm
    mold_z = (base_top, g.outer_height_mm + c.mold_wall_mm)
    return {
        "base": ((-math.sqrt(3) * (inr - rc) - rc, -inr, 0.0),
                 (math.sqrt(3) * (inr - rc) + rc, 2 * (inr - rc) + rc, base_top)),
        "prism": ((-g.prism_side_mm / 2, -g.prism_side_mm / 2, base_top - c.prism_embed_mm),
                  (g.prism_side_mm / 2, g.prism_side_mm / 2, base_top + g.prism_length_mm)),
        "cap": ((-half_cap, -half_cap, cap_z[0]),
                (half_w + g.nail_proud_mm, half_cap, cap_z[1])),
        "skin": ((-half_w, -half_w, cap_z[0]), (half_w, half_w, g.outer_height_mm)),
        "mold_a": ((mold_x[0], -mold_y, mold_z[0]), (mold_x[1], c.mold_key_length_mm, mold_z[1])),
        "mold_b": ((mold_x[0], 0.0, mold_z[0]), (mold_x[1], mold_y, mold_z[1])),
    }


@pytest.mark.parametrize("name", list(MATERIALS))
def test_exported_mesh_is_a_closed_solid_of_the_right_size(cad, name):
    mesh = cad.mesh(name)
    r = mesh_report(mesh)
    assert r.watertight, f"{name}.stl is not watertight"
    assert r.winding_consistent, f"{name}.stl has inconsistent winding"
    solid = getattr(cad.parts, name)
    assert r.volume == pytest.approx(solid.Volume(), rel=2e-3)
    lo, hi = expected_bounds(cad)[name]
    assert r.bounds[0] == pytest.approx(lo, abs=TOL), f"{name} lower corner"
    assert r.bounds[1] == pytest.approx(hi, abs=TOL), f"{name} upper corner"


@pytest.mark.parametrize("name", list(MATERIALS))
def test_exported_step_is_one_valid_solid(cad, name):
    shape = cq.importers.importStep(str(cad.out / f"{name}.step")).val()
    solids = shape.Solids()
    assert len(solids) == 1 and solids[0].isValid()
    assert solids[0].Volume() == pytest.approx(getattr(cad.parts, name).Volume(), rel=1e-6)


def test_the_envelope_is_the_papers(shipped):
    """19 x 19 mm of skin, 27 mm from the base's underside to the skin's top; the nail adds
    its 1 mm on the +x side only."""
    skin, cap = shipped.mesh("skin").bounds, shipped.mesh("cap").bounds
    assert skin[1] - skin[0] == pytest.approx((19.0, 19.0, skin[1][2] - skin[0][2]), abs=TOL)
    assert skin[1][2] == pytest.approx(27.0, abs=TOL)
    assert shipped.mesh("base").bounds[0][2] == pytest.approx(0.0, abs=TOL)
    assert cap[1][0] - skin[1][0] == pytest.approx(1.0, abs=TOL)
    for name in ("base", "prism", "cap"):
        b = shipped.mesh(name).bounds
        assert b[0][0] >= -9.5 - TOL and b[0][1] >= -9.5 - TOL and b[1][1] <= 9.5 + TOL


def test_assemblies_and_renders_are_written(shipped):
    for name in ("fingertip_assembly.step", "mold_assembly.step"):
        shape = cq.importers.importStep(str(shipped.out / name)).val()
        assert len(shape.Solids()) >= 7, name      # base, prism, cap, skin, piezo, screw, pcb...
    for name in ("cad_fingertip.png", "cad_mold.png"):
        data = (shipped.out / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000
