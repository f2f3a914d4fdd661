"""Strain channels: closed-form mechanics, exact bridge, HX711 counts, and the unit's flaws."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from fingertip.protocol import INT24_MAX, INT24_MIN, Sample, Start, StreamDecoder, encode
from fingertip.sim import VirtualFirmware
from fingertip.sim.physics import (
    Press,
    Realism,
    VirtualStrainSensor,
    cap_deflection_m,
    load,
    simulate,
)
from fingertip.sim.device.calibration_rig import calibration_sweep
from fingertip.sim.physics.scan import affine_scan, play_scan

def nominal(**on) -> VirtualStrainSensor:
    """The nominal unit with nothing but the model's imperfections named in ``on``."""
    return VirtualStrainSensor(variation=False, realism=dataclasses.replace(Realism.bare(), **on))


# --- closed form ------------------------------------------------------------------------------

@pytest.mark.parametrize("angle_deg", [0.0, 30.0, -50.0, 90.0, 135.0])
@pytest.mark.parametrize("height_mm", [0.0, 2.5, 5.0])
def test_surface_strain_is_the_bending_formula(angle_deg, height_mm):
    """eps = M c / (E I), M = F (z_contact - z_gauge), I = a^4 / 12, projected on each face."""
    s = nominal()
    e, a = 3.0e9, 6.0e-3                                   # PLA modulus, prism side (TOML)
    lever = (19.0 - height_mm - 4.5) * 1e-3                # nail tip z - height - gauge z
    f = 3.7
    phi = math.radians(angle_deg)
    eps = s.surface_strain([f * math.cos(phi), f * math.sin(phi)], height_mm)[0]
    m_c_over_ei = f * lever * (a / 2) / (e * a ** 4 / 12)
    # Face i faces 90 i degrees; the face the force pushes towards is compressed.
    expected = [-m_c_over_ei * math.cos(phi - math.radians(90 * i)) for i in range(4)]
    np.testing.assert_allclose(eps, expected, rtol=1e-12, atol=1e-18)
    if angle_deg == 0.0:                                   # force along x: y faces neutral
        assert abs(eps[1]) < 1e-18 and abs(eps[3]) < 1e-18
        assert eps[0] < 0 < eps[2]


def test_composite_section_and_axial_term():
    p = load().replace(geometry={"prism_core_side_mm": 4.0})
    s = VirtualStrainSensor(variation=False, realism=Realism.bare(), params=p)
    ei = 3.0e9 * 0.004 ** 4 / 12 + 26e6 * (0.006 ** 4 - 0.004 ** 4) / 12
    eps = s.surface_strain([1.0, 0.0], 0.0)[0]
    assert eps[2] == pytest.approx(1.0 * 14.5e-3 * 3e-3 / ei, rel=1e-12)
    ea = 3.0e9 * 0.004 ** 2 + 26e6 * (0.006 ** 2 - 0.004 ** 2)
    axial = s.surface_strain([0.0, 0.0], 0.0, force_z=2.0)[0]
    np.testing.assert_allclose(axial, -2.0 / ea, rtol=1e-12)


def test_gauge_reads_misalignment_poisson_and_transverse_sensitivity():
    s = nominal()
    th = math.radians(3.0)
    s.unit = dataclasses.replace(s.unit, gauge_angle_rad=np.full(4, th))
    p = s.params
    eps = s.surface_strain([2.0, 0.0], 1.0)
    gamma = np.zeros_like(eps)
    got = s.gauge_strain(eps, gamma)
    nu, kt, eta = p.materials.pla_poisson, p.gauge.transverse_sensitivity, p.gauge.glue_transfer
    along = eps * (math.cos(th) ** 2 - nu * math.sin(th) ** 2)
    across = eps * (math.sin(th) ** 2 - nu * math.cos(th) ** 2)
    np.testing.assert_allclose(got, eta * (along + kt * across), rtol=1e-12)


def test_bridge_is_the_exact_quarter_bridge():
    s = nominal()
    p = s.params
    eps = np.linspace(-3e-3, 3e-3, 13)[:, None] * np.ones(4)
    v = s.bridge_volts(eps)
    x = p.gauge.gauge_factor * eps
    np.testing.assert_allclose(v, p.hx711.excitation_v * x / (4 + 2 * x), rtol=1e-12, atol=1e-18)
    # With real resistors: the general two-divider formula, lead resistance in the gauge arm.
    s2 = VirtualStrainSensor(5, realism=Realism(thermal_response=False))
    u = s2.unit
    rg = u.gauge_ohm * (1 + u.gauge_factor * eps) + p.bridge.lead_resistance_ohm
    rc = u.completion_ohm
    ref = p.hx711.excitation_v * (rg / (rg + rc[:, 0]) - rc[:, 1] / (rc[:, 1] + rc[:, 2]))
    np.testing.assert_allclose(s2.bridge_volts(eps), ref, rtol=1e-12)


def test_counts_per_volt_and_per_newton():
    s = nominal()
    p = s.params
    f = 1.0
    c = s.counts([f, 0.0], 0.0, 0.0)
    # Along the grid: eps; across it: -nu eps, seen through the transverse sensitivity.
    eps = p.strain_per_newton * p.gauge.glue_transfer \
        * (1 - p.gauge.transverse_sensitivity * p.materials.pla_poisson)
    x = p.gauge.gauge_factor * eps
    volts = p.hx711.excitation_v * x / (4 + 2 * x)
    assert c[2] == round(volts * 2 ** 23 / (0.5 * 4.3 / 128))
    assert 130_000 < c[2] < 155_000                        # about 142k counts per newton


def test_scans_match_their_recurrences():
    rng = np.random.default_rng(0)
    a, b = rng.uniform(0.3, 1, (300, 4)), rng.normal(size=(300, 4))
    x, ref = np.ones(4), []
    for k in range(300):
        x = a[k] * x + b[k]
        ref.append(x)
    np.testing.assert_allclose(affine_scan(a, b, np.ones(4)), ref, rtol=1e-12)
    u = np.cumsum(rng.normal(size=(300, 4, 3)), axis=0)
    r = np.array([0.2, 1.0, 3.0])
    p, ref = np.zeros((4, 3)), []
    for k in range(300):
        p = np.clip(p, u[k] - r, u[k] + r)
        ref.append(p)
    np.testing.assert_array_equal(play_scan(u, r, np.zeros((4, 3))), ref)


# --- the paper's characterisation -------------------------------------------------------------

def test_linear_at_a_fixed_angle_without_hysteresis_and_creep():
    # The room's temperature drift is no non-linearity: hold the temperature.
    s = VirtualStrainSensor(2, realism=Realism(thermal=False, hysteresis=False,
                                               short_creep=False, creep=False, mount=False))
    sw = calibration_sweep(s, seed=2, angles_deg=(-30, 0, 40), heights_mm=(2,))
    for angle in (-30, 0, 40):
        m = sw.angle_deg == angle
        f = np.hypot(sw.fx[m], sw.fy[m])
        assert f.max() > 4.4 and f.min() == 0.0
        for ch in range(4):
            y = sw.counts[m, ch].astype(float)
            a = np.column_stack([f, np.ones_like(f)])
            coef, *_ = np.linalg.lstsq(a, y, rcond=None)
            if abs(coef[0]) < 2000:                        # a neutral face: only noise
                continue
            r2 = 1 - ((y - a @ coef) ** 2).sum() / ((y - y.mean()) ** 2).sum()
            assert r2 > 0.99, (angle, ch, r2)


def loop_area(sensor: VirtualStrainSensor, channel: int = 2) -> tuple[float, float]:
    """Area enclosed by counts against force over 0 -> 5 N -> 0, and the bounding box."""
    r = simulate(Press(peak_n=5.0, ramp_s=4.0, hold_s=0.0, pre_s=0.1, post_s=0.1),
                 sensor=sensor)
    f = np.hypot(r.force.fx, r.force.fy)
    c = r.force.counts[:, channel].astype(float)
    area = -float(np.sum((c[1:] + c[:-1]) / 2 * np.diff(f)))  # closed loop, counter-clockwise
    return area, float(np.ptp(f) * np.ptp(c))


def test_hysteresis_loop_has_positive_area_only_when_on():
    area_on, box = loop_area(nominal(hysteresis=True))
    assert 0.005 < area_on / box < 0.1                     # measurable, a few percent
    area_off, box = loop_area(nominal())
    assert abs(area_off) / box < 1e-9
    # Unloading reads higher than loading at the same force; zero is not quite returned to.
    r = simulate(Press(peak_n=5.0, ramp_s=4.0, hold_s=0.0, pre_s=0.1, post_s=0.1),
                 sensor=nominal(hysteresis=True))
    f, c = np.hypot(r.force.fx, r.force.fy), r.force.counts[:, 2]
    up = np.flatnonzero((np.diff(f, prepend=0) > 0) & (np.abs(f - 2.5) < 0.05))
    down = np.flatnonzero((np.diff(f, prepend=0) < 0) & (np.abs(f - 2.5) < 0.05))
    assert c[down].mean() > c[up].mean()
    assert c[-1] > 0


def test_creep_rises_after_a_load_step_and_recovers():
    s = nominal(short_creep=True)
    tau, frac = s.unit.creep_tau_s[2], s.unit.creep_fraction[2]
    t = np.arange(0, 30, 0.1)
    load_on = (t < 15).astype(float) * 4.0
    c = s.counts_batch(np.column_stack([load_on, 0 * t]), 0.0, t)[:, 2].astype(float)
    first, settled = c[0], c[149]
    assert settled / first == pytest.approx(1 + frac * (1 - math.exp(-14.9 / tau)), rel=1e-3)
    after = c[150:]
    # Creep recovery: the unloaded reading starts at the crept part and relaxes to zero.
    crept = frac * first * (1 - math.exp(-14.9 / tau)) * math.exp(-0.1 / tau)
    assert after[0] == pytest.approx(crept, rel=1e-3)
    assert abs(after[-1]) < abs(after[0]) / 50


def test_temperature_drift_moves_offset_and_span():
    # The gauges' own thermal output (no completion-resistor TCR: realism source "thermal").
    held = Realism(thermal=False, hx711_noise=False, hysteresis=False, short_creep=False,
                   creep=False, mount=False)
    ref = VirtualStrainSensor(4, temperature_c=25.0, realism=held)
    warm = VirtualStrainSensor(4, temperature_c=26.0, realism=held)
    zero = warm.counts([0, 0], 0, 0.0) - ref.counts([0, 0], 0, 0.0)
    # (PLA CTE - steel compensation) ~ 57 ue/K of apparent strain, ~1.1e3 counts per ue.
    assert np.all((zero > 45_000) & (zero < 85_000))
    span_ref = ref.counts([4, 0], 0, 1.0) - ref.counts([0, 0], 0, 1.0)
    span_warm = warm.counts([4, 0], 0, 1.0) - warm.counts([0, 0], 0, 1.0)
    assert abs(span_warm[2]) > abs(span_ref[2]) * 1.001      # PLA softens: more strain per N
    ramp = VirtualStrainSensor(4, temperature_c=lambda t: 25.0 + 0.1 * t)
    c = ramp.counts_batch(np.zeros((11, 2)), 0.0, np.arange(11.0))
    assert np.all(np.diff(c[:, 0]) > 0)


def test_saturates_at_the_24_bit_limits():
    s = nominal()
    c = s.counts([200.0, 0.0], 0.0, 0.0)
    assert c[0] == INT24_MIN and c[2] == INT24_MAX
    raw = s.raw_counts_batch([[200.0, 0.0]], 0.0, [0.1])[0]
    assert raw[2] > INT24_MAX                              # the source gives the unclipped value
    assert s.counts([4.0, 0.0], 0.0, 0.2)[2] < INT24_MAX


def test_noise_follows_the_hx711_rate():
    for rate, nv in ((10, 50e-9), (80, 90e-9)):
        s = VirtualStrainSensor(variation=False, rate_sps=rate,
                                realism=Realism(hysteresis=False, short_creep=False,
                                                offsets=False).only("hx711_noise"))
        c = s.counts_batch(np.zeros((4000, 2)), 0.0, np.arange(4000) / rate)
        expected = nv * s.params.hx711.counts_per_volt
        assert c.std(axis=0) == pytest.approx(np.full(4, expected), rel=0.1)


# --- units, seeds, state ----------------------------------------------------------------------

def test_same_seed_same_unit_and_counts_different_seed_different_unit():
    forces = np.column_stack([np.linspace(0, 5, 200), np.linspace(0, -2, 200)])
    t = np.arange(200) / 80
    a = VirtualStrainSensor(7).counts_batch(forces, 1.0, t)
    b = VirtualStrainSensor(7).counts_batch(forces, 1.0, t)
    c = VirtualStrainSensor(8).counts_batch(forces, 1.0, t)
    np.testing.assert_array_equal(a, b)
    assert np.abs(a - c).max() > 10_000
    u7, u8 = VirtualStrainSensor(7).unit, VirtualStrainSensor(8).unit
    assert not np.allclose(u7.gauge_angle_rad, u8.gauge_angle_rad)
    np.testing.assert_array_equal(calibration_sweep(seed=3).counts,
                                  calibration_sweep(seed=3).counts)


def test_single_calls_equal_the_batch_path():
    forces = np.column_stack([np.sin(np.arange(50) / 5) * 3, np.cos(np.arange(50) / 7)])
    t = np.arange(50) / 80
    batch = VirtualStrainSensor(9).counts_batch(forces, 2.0, t)
    s = VirtualStrainSensor(9)
    single = np.array([s.counts(f, 2.0, tt) for f, tt in zip(forces, t, strict=True)])
    np.testing.assert_array_equal(single, batch)
    with pytest.raises(ValueError, match="backwards"):
        s.counts([0, 0], 0, 0.0)


def test_chunked_scans_give_the_same_counts(monkeypatch):
    from fingertip.sim.physics import strain
    forces = np.column_stack([np.abs(np.sin(np.arange(300) / 9)) * 5, np.zeros(300)])
    t = np.arange(300) / 80
    whole = VirtualStrainSensor(4).counts_batch(forces, 0.0, t)
    monkeypatch.setattr(strain, "CHUNK", 7)
    np.testing.assert_array_equal(VirtualStrainSensor(4).counts_batch(forces, 0.0, t), whole)


def _fit(counts, fx, fy):
    a = np.column_stack([counts.astype(float), np.ones(len(fx))])
    w, *_ = np.linalg.lstsq(a, np.column_stack([fx, fy]), rcond=None)
    return w


def _rmse(w, counts, fx, fy):
    a = np.column_stack([counts.astype(float), np.ones(len(fx))])
    return float(np.sqrt(((a @ w - np.column_stack([fx, fy])) ** 2).sum(axis=1).mean()))


def test_each_unit_needs_its_own_calibration():
    kw = dict(angles_deg=(-40, -20, 0, 20, 40), heights_mm=(1, 3))
    a = calibration_sweep(VirtualStrainSensor(1), seed=10, **kw)
    a2 = calibration_sweep(VirtualStrainSensor(1), seed=11, **kw)
    b = calibration_sweep(VirtualStrainSensor(2), seed=12, **kw)

    def tared(sw):
        return sw.counts - sw.counts[sw.step == sw.step.max()].mean(axis=0)

    wa = _fit(tared(a), a.fx, a.fy)
    own = _rmse(wa, tared(a2), a2.fx, a2.fy)
    cross = _rmse(wa, tared(b), b.fx, b.fy)
    noise_n = 90e-9 * load().hx711.counts_per_volt / 130_000   # noise in newtons, ~0.3 mN
    assert own < 0.3
    assert cross > 3 * own and cross > 100 * noise_n
    wb = _fit(tared(b), b.fx, b.fy)
    assert np.abs(wa[:4] - wb[:4]).max() > 0.05 * np.abs(wa[:4]).max()


def test_feeds_the_virtual_firmware():
    scene = Press(angle_deg=90.0, peak_n=3.0, ramp_s=0.5, hold_s=0.2, pre_s=0.1, post_s=0.2)
    # The chips' first conversion comes 4 periods after power-up: start the scene 3 periods
    # in, so that the firmware's first read is the scene's first sample.
    t0 = 3 * 12_500
    fw = VirtualFirmware(4, source=VirtualStrainSensor(3).as_source(scene, t0_us=t0))
    fw.boot()
    dec = StreamDecoder("device")
    dec.feed(fw.receive(encode(Start(1))))
    samples = [m for m in dec.feed(fw.advance(t0 + int(scene.duration_s * 1e6)))
               if isinstance(m, Sample)]
    direct = simulate(scene, seed=3, t0_us=t0).force        # same unit, same noise stream
    assert len(samples) == len(direct.t_us)
    np.testing.assert_array_equal([m.timestamp_us for m in samples], direct.t_us)
    np.testing.assert_array_equal([m.values for m in samples], direct.counts)
    peak = int(np.argmax(direct.fy))
    assert samples[peak].values[1] - samples[0].values[1] < -300_000   # +y face compressed


def test_the_cap_stays_clear_of_the_prism_at_full_load():
    p = load()
    d = cap_deflection_m(p, 5.0, 0.0)
    assert d["gap_closure"] < p.geometry.cap_gap_mm * 1e-3 / 10
    assert 0 < d["nail"] < 1e-3
