"""No printed wall is thinner than min_wall_mm (ray casting inward from surface samples)."""
from __future__ import annotations

import pytest
import trimesh

from fingertip_cad.checks import wall_thickness

PRINTED = ("base", "prism", "cap", "mold_a", "mold_b")


@pytest.mark.parametrize("name", PRINTED)
def test_no_printed_wall_is_thinner_than_the_minimum(cad, name):
    wall = cad.dims.p.cad.min_wall_mm
    thickness, where = wall_thickness(cad.mesh(name), samples=6000)
    assert thickness >= wall - 0.01, f"{name}: {thickness:.3f} mm wall at {where.round(2)}"


def test_the_wall_check_finds_a_thin_wall():
    """The checker itself: a 0.5 mm plate is reported as 0.5 mm, a 3 mm cube as 3 mm."""
    plate = trimesh.creation.box((10.0, 10.0, 0.5))
    assert wall_thickness(plate, samples=2000)[0] == pytest.approx(0.5, abs=1e-3)
    cube = trimesh.creation.box((3.0, 3.0, 3.0))
    assert wall_thickness(cube, samples=2000)[0] == pytest.approx(3.0, abs=1e-3)
    tube = trimesh.creation.annulus(r_min=2.0, r_max=2.6, height=5.0, sections=64)
    assert wall_thickness(tube, samples=4000)[0] == pytest.approx(0.6, abs=0.02)
