"""The CAD's parameters: one file with the physics model, overrides, impossible sets refused,
and the prism's strain per newton from the very geometry the CAD builds."""
from __future__ import annotations

import pytest

from fingertip.sim.physics import load
from fingertip_cad import Dims, load_params
from fingertip_cad.cli import main
from fingertip_cad.config import parse_override


def test_the_cad_reads_the_physics_models_file():
    assert load_params() == load()


def test_overrides_are_parsed_as_toml_values():
    assert parse_override("geometry.outer_width_mm=22") == ("geometry", "outer_width_mm", 22)
    assert parse_override("mount.mount_hole_angles_deg=[0, 120, 240]")[2] == [0, 120, 240]
    with pytest.raises(ValueError, match="section.key=value"):
        parse_override("outer_width_mm=22")
    with pytest.raises(ValueError, match="no such key"):
        load_params(overrides=["geometry.outer_widht_mm=22"])


@pytest.mark.parametrize("overrides, message", [
    ({"geometry.cap_gap_mm": 5.0}, "cap wall"),                       # the cap wall vanishes
    ({"geometry.cap_gap_mm": 4.4}, "thinner than min_wall_mm"),        # 0.6 mm of cap wall
    ({"geometry.skin_mm": 2.0}, "outer_height_mm"),                    # heights don't add up
    ({"cad.piezo_seat_depth_mm": 0.6}, "piezo"),
    ({"piezo.diameter_mm": 15.0}, "piezo seat"),
    ({"cad.prism_embed_mm": 3.0}, "base_height_mm"),                   # root into the pocket
    ({"cad.nail_height_mm": 25.0}, "nail"),
    ({"cad.screw_length_mm": 12.0}, "cap screw"),
    ({"cad.mold_key_diameter_mm": 4.0}, "mold_key_diameter_mm"),
    ({"geometry.prism_side_mm": 6.8}, "wire hole"),                    # [mount] holes in prism
    ({"mount.mount_hole_radius_mm": 8.5}, "mount hole"),               # off the base's edge
    ({"cad.pocket_wall_mm": 2.2}, "pocket"),
])
def test_impossible_parameter_sets_are_refused_clearly(overrides, message):
    with pytest.raises(ValueError, match=message):
        Dims(load_params(overrides=overrides))


def test_the_cli_refuses_them_too(capsys):
    assert main(["--summary", "--set", "geometry.cap_gap_mm=5"]) == 2
    assert "cap wall" in capsys.readouterr().err
    assert main(["--summary", "--set", "geometry.outer_width_mm=22"]) == 0
    assert "ue/N" in capsys.readouterr().out


def test_strain_per_newton_uses_the_built_geometry(cad):
    """Measure the prism's side, the gauge's height and the nail tip on the solids, feed them to
    the physics model's closed form, and get the CAD's number back."""
    d = cad.dims
    prism = cad.mesh("prism").bounds
    side = prism[1][0] - prism[0][0]
    base_top = cad.mesh("base").bounds[1][2]
    assert prism[1][2] - base_top == pytest.approx(d.p.geometry.prism_length_mm, abs=1e-6)
    # The gauge's centre: half a backing above the top of the face's wire channel (the
    # highest vertex of the channel's floor, measured on the mesh).
    v = cad.mesh("prism").vertices
    floor = v[abs(v[:, 0] - (side / 2 - d.p.cad.wire_channel_depth_mm)) < 1e-6]
    gauge_z = floor[:, 2].max() + d.p.gauge.backing_length_mm / 2 - base_top
    cap = cad.mesh("cap")
    nail_top = cap.vertices[cap.vertices[:, 0] > d.half_skin + 1e-6][:, 2].max() - base_top
    measured = d.p.replace(geometry={"prism_side_mm": side, "prism_core_side_mm": side,
                                     "gauge_center_z_mm": gauge_z, "nail_tip_z_mm": nail_top})
    assert measured.strain_per_newton == pytest.approx(d.strain_per_newton, rel=1e-9)
    assert d.strain_per_newton == d.p.strain_per_newton
    if cad.name == "shipped":
        assert d.strain_per_newton * 1e6 == pytest.approx(134.26, abs=0.01)
