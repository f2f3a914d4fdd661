"""The documented error sources of the strain path: switches, sizes and their physics."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fingertip.sim.physics import Realism, VirtualStrainSensor
from fingertip.sim.device.calibration_rig import calibration_sweep
from fingertip.sim.physics import realism as rl

QUIET = {"hysteresis": False, "short_creep": True, "thermal_response": False,
         "offsets": False, "shunt": False}
"""The model's own imperfections for the creep tests: its short creep alone."""


def test_switches():
    assert Realism().active == Realism.sources()
    assert Realism.none().active == ()
    assert Realism().without("creep", "skin").active == tuple(
        n for n in Realism.sources() if n not in ("creep", "skin"))
    assert Realism().only("thermal").active == ("thermal",)
    assert Realism.ideal().active == ("hx711_noise", "unit_spread")
    with pytest.raises(ValueError, match="unknown error source"):
        Realism().without("gremlins")


def test_parameter_file_is_strict():
    import tomllib

    from fingertip.sim.physics.realism import REALISM_FILE, from_dict
    from importlib import resources

    text = resources.files("fingertip.sim.physics").joinpath(REALISM_FILE).read_text()
    data = tomllib.loads(text)
    assert from_dict(data) == rl.load()
    bad = {**data, "creep": {**data["creep"], "extra": 1}}
    with pytest.raises(ValueError, match="unknown keys"):
        from_dict(bad)
    bad = {**data, "skin": {**data["skin"], "relax_fraction": [0.6, 0.5]}}
    with pytest.raises(ValueError, match="less than 1"):
        from_dict(bad)
    bad = {**data, "mount": {**data["mount"], "relax_tau_s": [30.0]}}
    with pytest.raises(ValueError, match="differ in length"):
        from_dict(bad)


def test_sizes_follow_the_sources():
    p = rl.load()
    assert p.hx711_drift.offset_nv_per_k == 6.0 and p.hx711_drift.gain_ppm_per_k == 5.0
    # Mold Star 20T, Shore 20A: Gent's relation gives 0.73 MPa.
    s = 20.0
    gent = 0.0981 * (56 + 7.66 * s) / (0.137505 * (254 - 2.54 * s))
    assert p.skin.modulus_mpa == pytest.approx(gent, abs=0.01)
    assert p.skin.relaxation(0.0) == pytest.approx(1.0)
    assert p.skin.relaxation(1e6) == pytest.approx(1 - sum(p.skin.relax_fraction))


def test_slow_creep_step_response_and_state():
    c = rl.SlowCreep(np.array([[0.1, 0.05]] * 4), np.array([10.0, 100.0]))
    t = np.arange(0, 300, 0.5)
    x = np.ones((len(t), 4))
    y = c.apply(x, t)
    want = 1 + 0.1 * (1 - np.exp(-t / 10)) + 0.05 * (1 - np.exp(-t / 100))
    np.testing.assert_allclose(y[:, 0], want, rtol=1e-9)
    # The same history in two calls gives the same result (state carries over).
    c2 = rl.SlowCreep(c.fraction, c.tau_s)
    y2 = np.concatenate([c2.apply(x[:300], t[:300]), c2.apply(x[300:], t[300:])])
    np.testing.assert_allclose(y2, y, rtol=1e-12)
    with pytest.raises(ValueError, match="backwards"):
        c2.apply(x[:2], np.array([1.0, 0.5]))
    # Nothing to do: no copy, no state.
    z = rl.SlowCreep(np.zeros((4, 2)), np.array([1.0, 2.0]))
    assert z.apply(x, t) is x and z.apply(x[:0], t[:0]).shape == (0, 4)


def test_creep_source_reads_more_under_a_held_load():
    def held(realism: Realism) -> tuple[float, VirtualStrainSensor]:
        s = VirtualStrainSensor(3, variation=False,
                                realism=dataclasses.replace(realism, **QUIET))
        c = s.counts_batch(np.array([[4.0, 0.0]] * 2), 0.0, [1.0, 600.0])[:, 2].astype(float)
        return c[1] / c[0], s

    without, s0 = held(Realism.none())
    assert without == pytest.approx(1 + s0.unit.creep_fraction[2], rel=1e-4)  # the short creep
    with_creep, s1 = held(Realism().only("creep"))
    f, tau = s1.real.creep_fraction[2], s1.real.creep_tau_s
    slow = 1 + float(np.sum(f * (1 - np.exp(-599.0 / tau))))
    assert with_creep == pytest.approx(without * slow, rel=1e-4)
    # PLA and glue after 10 min of a held load: a few per cent more.
    assert 0.02 < slow - 1 < 0.12


def test_eccentric_vertical_force_opposes_the_lateral_moment():
    off = VirtualStrainSensor(variation=False, realism=Realism.bare())
    on = VirtualStrainSensor(variation=False, realism=Realism.bare().only("contact"))
    f, fz = np.array([[2.0, 0.0]]), 0.5
    plain = off.surface_strain(f, 0.0)
    # +x force: the +x face (channel 0) is compressed. A downward (compressive) force at the
    # contact, on the -x side, tilts the cap the other way and relieves it.
    assert plain[0, 0] < 0
    diff = on.surface_strain(f, 0.0, fz) - off.surface_strain(f, 0.0, fz)
    r = rl.load().contact.surface_radius_mm * 1e-3
    lever = off.params.geometry.lever_m(0.0)
    assert diff[0, 0] == pytest.approx(-plain[0, 0] * r * fz / (2.0 * lever), rel=1e-9)
    assert diff[0, 2] == pytest.approx(-diff[0, 0], rel=1e-9)
    # No lateral force: no side contact, no eccentric moment.
    np.testing.assert_array_equal(on.surface_strain(np.zeros((1, 2)), 0.0, 1.0),
                                  off.surface_strain(np.zeros((1, 2)), 0.0, 1.0))


def test_lab_temperature_and_resistor_drift():
    s = VirtualStrainSensor(5)
    t = np.linspace(0, 6 * 3600, 2000)
    temp = s.temperature_at(t)
    p = rl.load().thermal
    assert np.ptp(temp) < 2 * (p.hvac_amplitude_k + p.drift_amplitude_k) + 1e-9
    assert np.ptp(temp) > 0.5
    assert np.all(np.abs(s.real.completion_tcr_per_k) <= p.completion_tcr_ppm_per_k * 1e-6)
    off = VirtualStrainSensor(5, realism=Realism(thermal=False))
    assert np.all(off.temperature_at(t) == off.params.thermal.reference_c)
    assert np.all(off.real.completion_tcr_per_k == 0)
    # An explicit temperature wins over the room's.
    fixed = VirtualStrainSensor(5, temperature_c=27.0)
    assert np.all(fixed.temperature_at(t) == 27.0)


def test_switching_one_source_leaves_the_others_draws_alone():
    a = VirtualStrainSensor(7)
    b = VirtualStrainSensor(7, realism=Realism().without("creep"))
    assert a.real.hvac_period_s == b.real.hvac_period_s
    np.testing.assert_array_equal(a.real.completion_tcr_per_k, b.real.completion_tcr_per_k)
    np.testing.assert_array_equal(a.unit.gauge_angle_rad, b.unit.gauge_angle_rad)
    sa = calibration_sweep(VirtualStrainSensor(7), seed=3, angles_deg=(0,), heights_mm=(2,))
    sb = calibration_sweep(VirtualStrainSensor(7, realism=Realism().without("creep")), seed=3,
                           angles_deg=(0,), heights_mm=(2,))
    np.testing.assert_array_equal(sa.fx, sb.fx)


def test_sweep_contact_and_skin():
    kw = dict(seed=4, angles_deg=(-30, 20), heights_mm=(1, 4))
    ideal = calibration_sweep(VirtualStrainSensor(2, realism=Realism.none()), **kw)
    real = calibration_sweep(VirtualStrainSensor(2), **kw)
    assert len(ideal) == len(real) == 4 * 40
    np.testing.assert_array_equal(ideal.angle_deg, real.angle_deg)   # logged: nominal
    np.testing.assert_array_equal(ideal.height_mm, real.height_mm)
    ang = np.degrees(np.arctan2(real.fy, real.fx))
    m = np.hypot(real.fx, real.fy) > 0.5
    dev = ang[m] - real.angle_deg[m]
    assert 0 < np.abs(dev).max() < 10                                  # the fixture's spread
    # The readings' force law is kept (the skin relaxes towards it during the pause).
    assert np.hypot(real.fx, real.fy).max() <= 5.0
