"""The parameter file: one source of truth, strictly loaded, consistent with the paper."""
from __future__ import annotations

import tomllib

import pytest

from fingertip.sim.physics import cap_deflection_m, load, params_path
from fingertip.sim.physics.params import from_dict


def test_shipped_file_loads_and_matches_the_paper():
    p = load()
    assert params_path().is_file()
    g = p.geometry
    assert (g.outer_width_mm, g.outer_height_mm) == (19.0, 27.0)        # 1.9 x 1.9 x 2.7 cm
    assert g.cap_gap_mm == 1.0 and g.nail_proud_mm == 1.0
    assert p.gauge.model == "BF120-3AA" and p.gauge.resistance_ohm == 120.0
    assert (p.gauge.backing_width_mm, p.gauge.backing_length_mm) == (4.0, 6.8)
    assert 2.0 <= p.gauge.gauge_factor <= 2.1
    assert p.hx711.gain == 128 and p.hx711.bits == 24
    assert p.soundcard.sample_rate_hz == 44100
    # The envelope holds the prism, the gap, a cap wall and the skin, across and along.
    assert g.cap_wall_mm > 2.0
    assert g.base_height_mm + g.prism_length_mm + g.cap_roof_mm + p.piezo.thickness_mm \
        + g.skin_mm == pytest.approx(g.outer_height_mm)


def test_hx711_scale_follows_the_datasheet():
    p = load()
    at5v = p.replace(hx711={"avdd_v": 5.0, "excitation_v": 5.0}).hx711
    assert at5v.full_scale_v == pytest.approx(0.5 * 5.0 / 128)            # +-19.5 mV ("20 mV")
    assert at5v.counts_per_volt == pytest.approx(2 ** 23 / (2.5 / 128))
    # Ratiometric: the bridge is excited from AVDD, so counts per strain do not depend on it.
    assert p.counts_per_strain == pytest.approx(
        p.replace(hx711={"avdd_v": 5.0, "excitation_v": 5.0}).counts_per_strain)
    with pytest.raises(ValueError):
        p.hx711.noise_v_rms(15)


def test_loader_rejects_unknown_and_missing_keys():
    data = tomllib.loads(params_path().read_text())
    data["gauge"]["gauge_factr"] = 2.0
    with pytest.raises(ValueError, match="gauge_factr"):
        from_dict(data)
    data = tomllib.loads(params_path().read_text())
    del data["hx711"]["gain"]
    with pytest.raises(ValueError, match="gain"):
        from_dict(data)
    data = tomllib.loads(params_path().read_text())
    data["geometry"]["prism_side_mm"] = 16.0                             # no room for the cap
    with pytest.raises(ValueError, match="cap wall"):
        from_dict(data)


def test_load_from_a_path(tmp_path):
    text = params_path().read_text().replace("gauge_factor = 2.08", "gauge_factor = 2.05")
    f = tmp_path / "unit.toml"
    f.write_text(text)
    assert load(f).gauge.gauge_factor == 2.05


def test_the_cap_stays_clear_of_the_prism_at_full_load():
    p = load()
    d = cap_deflection_m(p, 5.0, 0.0)
    assert d["gap_closure"] < p.geometry.cap_gap_mm * 1e-3 / 10
    assert 0 < d["nail"] < 1e-3
