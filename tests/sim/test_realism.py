"""The documented error sources of the strain path: switches, sizes and their physics."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fingertip.sim.paper_method import (
    PAPER_SPLIT,
    TaskShakes,
    mse,
    paper_force_model,
    paper_task_votes,
    paper_votes,
    random_split,
    spectrogram,
    task_shakes,
    trial_split,
    windows,
    WINDOW_FRAMES,
    force_session,
)
from fingertip.sim.physics import Realism, VirtualStrainSensor, calibration_sweep
from fingertip.sim.physics import realism as rl
from fingertip.sim.physics.strain import Effects

QUIET = Effects(hysteresis=False, creep=True, thermal=False, noise=False, offsets=False,
                shunt=False)


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
        s = VirtualStrainSensor(3, variation=False, effects=QUIET, realism=realism)
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
    off = VirtualStrainSensor(variation=False, effects=Effects.ideal(), realism=Realism.none())
    on = VirtualStrainSensor(variation=False, effects=Effects.ideal(),
                             realism=Realism().only("contact"))
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


def test_splits():
    tr, te = random_split(100, 0, 0.2)
    assert len(te) == 20 and len(np.intersect1d(tr, te)) == 0 and len(tr) + len(te) == 100
    with pytest.raises(ValueError):
        random_split(10, 0, 1.0)
    s = force_session(1)
    tr, te = trial_split(s, 0)
    assert not set(s.sweep.trial[tr]) & set(s.sweep.trial[te])
    assert len(tr) + len(te) == len(s.counts) == 2640


def test_mse_is_the_vector_mean():
    assert mse(np.array([[3.0, 4.0], [0.0, 0.0]]), np.zeros((2, 2))) == 12.5
    # PyTorch's MSELoss / scikit-learn's convention: the mean over components too.
    assert mse(np.array([[3.0, 4.0], [0.0, 0.0]]), np.zeros((2, 2)), per_component=True) \
        == 6.25


def test_paper_split_holds_out_whole_trials():
    assert PAPER_SPLIT == "trials"


def test_rest_readings_before_each_trial():
    """Each row carries the reading at rest just before its trial's contact: the indenter is
    clear (the true force is zero) and, with the room and the slow creep drifting, it moves
    from trial to trial."""
    sensor = VirtualStrainSensor(5)
    sw = calibration_sweep(sensor, seed=2, angles_deg=(-20, 0, 30), heights_mm=(0, 3))
    assert sw.rest_counts.shape == sw.counts.shape
    per_trial = {int(k): sw.rest_counts[sw.trial == k] for k in np.unique(sw.trial)}
    for rows in per_trial.values():
        assert np.all(rows == rows[0])                  # one rest reading per trial
    rests = np.stack([r[0] for r in per_trial.values()])
    assert np.ptp(rests, axis=0).max() > 0              # it drifts between trials
    # A rest reading is what the sensor reads with no force: close to the unloaded rows
    # (the first step is before contact: travel 1.5 mm, contact at 2-8 mm).
    first = sw.step == 0
    assert np.all(np.hypot(sw.fx[first], sw.fy[first]) == 0)
    dev = np.abs(sw.counts[first] - sw.rest_counts[first]).max()
    assert dev < 0.02 * np.abs(sw.counts).max()
    sub = sw.select(sw.trial == sw.trial[0])
    np.testing.assert_array_equal(sub.rest_counts, sw.rest_counts[sw.trial == sw.trial[0]])
    s = force_session(5)
    np.testing.assert_array_equal(s.retared_counts, s.sweep.counts - s.sweep.rest_counts)


def test_paper_force_model_learns_a_linear_map():
    rng = np.random.default_rng(0)
    x = rng.normal(0, 1e5, (800, 4))
    y = x[:, :2] * 1e-5 - x[:, 2:] * 5e-6
    pred = paper_force_model(x[:600], y[:600], epochs=200)
    assert mse(pred(x[600:]), y[600:]) < 0.01 * mse(np.zeros_like(y[600:]), y[600:])


def test_spectrogram_windows():
    fs = 44100
    t = np.arange(fs) / fs
    x = np.sin(2 * math.pi * 5000 * t)
    spec = spectrogram(x)
    assert spec.shape == (1 + (fs - 512) // 256, 32)
    band = int(np.argmax(spec.mean(axis=0)))
    assert band == int(5000 / (fs / 2) * 32)                 # the tone's band
    w = windows(spec)
    assert w.shape[1] == WINDOW_FRAMES * 32 and len(w) == 1 + (len(spec) - WINDOW_FRAMES) // 17
    short = windows(spectrogram(x[:fs // 4]))                # shorter than one window
    assert short.shape == (1, WINDOW_FRAMES * 32)
    assert np.all(np.isfinite(spectrogram(np.zeros(100))))   # silence and a short input


def test_paper_votes_one_vote_per_held_out_recording():
    """Tones tell three classes apart; one recording of class 0 is a class-1 tone (a
    mislabelled shake): its vote is wrong whatever the model, so the accuracy is 11/12."""
    fs = 44100
    t = np.arange(fs // 2) / fs                      # one (padded) window per recording
    rng = np.random.default_rng(0)
    freqs = (1000.0, 6000.0, 14000.0)
    xs, ys = [], []
    for k in range(12):
        c = k % 3
        f = freqs[1] if k == 0 else freqs[c]
        xs.append(np.sin(2 * math.pi * f * t) + 0.01 * rng.standard_normal(len(t)))
        ys.append(c)
    r = paper_votes(xs, np.array(ys), ["screws", "rubber_bands", "empty"], folds=4, epochs=30)
    assert r.recordings == 12 and r.correct == 11
    assert r.accuracy == pytest.approx(11 / 12)
    assert r.box_accuracy == pytest.approx(7 / 8)           # classes 0 and 1 only
    assert r.window_accuracy == pytest.approx(11 / 12)      # one window each
    with pytest.raises(ValueError):
        paper_votes(xs[:3], np.array(ys[:3]), ["a", "b", "c"], folds=5)


def test_task_shakes_vary_as_the_task_scene():
    """The task's test shakes: boxes only, the scene's fill and amplitude, and a microphone
    gain and mains drawn per shake within the task scene's ranges (off: the file's)."""
    from fingertip.sim.dataset import TASK_MAINS_HZ, TASK_PREAMP_GAIN
    from fingertip.sim.physics import load

    classes = ["empty", "rubber_bands", "screws"]
    t = task_shakes(classes, 3, seed=5)
    assert sorted(t.labels.tolist()) == [1, 1, 1, 2, 2, 2]
    base = load().preamp.gain
    lo, hi = TASK_PREAMP_GAIN
    assert np.all((t.preamp_gain >= base * lo) & (t.preamp_gain <= base * hi))
    assert set(t.mains_hz.tolist()) <= set(TASK_MAINS_HZ)
    assert len(set(t.preamp_gain.tolist())) == 6                 # one draw per shake
    assert all(len(x) >= int(5.6 * 44100) for x in t.recordings)
    again = task_shakes(classes, 3, seed=5)
    assert all(np.array_equal(a, b) for a, b in zip(t.recordings, again.recordings, strict=True))
    quiet = task_shakes(classes, 3, seed=5, microphone=False)
    assert np.all(quiet.preamp_gain == base)
    assert np.all(quiet.mains_hz == load().mains.frequency_hz)
    # the same scenes (fill, grip, amplitude) at another gain: louder where the gain is higher
    louder = t.preamp_gain > base * 1.1
    rms = [float(np.sqrt(np.mean(x ** 2))) for x in t.recordings]
    rms_q = [float(np.sqrt(np.mean(x ** 2))) for x in quiet.recordings]
    assert louder.any()
    assert all(a > b for a, b, up in zip(rms, rms_q, louder, strict=True) if up)
    with pytest.raises(ValueError, match="lack the boxes"):
        task_shakes(["empty", "screws"], 1)


def test_paper_task_votes_train_once_vote_per_box():
    """Tones: trained once on the collection, one vote per test shake; a rubber-band shake
    that sounds like screws is a miss of that box only."""
    fs = 44100
    t = np.arange(fs // 2) / fs
    rng = np.random.default_rng(1)
    freqs = {"empty": 14000.0, "rubber_bands": 1000.0, "screws": 6000.0}
    classes = sorted(freqs)

    def tone(f):
        return np.sin(2 * math.pi * f * t) + 0.01 * rng.standard_normal(len(t))

    xs = [tone(freqs[c]) for c in classes for _ in range(4)]
    ys = np.repeat(np.arange(3), 4)
    test_x = [tone(freqs["screws"]), tone(freqs["rubber_bands"]), tone(freqs["screws"])]
    test = TaskShakes(test_x, np.array([2, 1, 1]), np.ones(3), np.full(3, 50.0))
    r = paper_task_votes((xs, ys, classes), test, epochs=30)
    assert r.per_box == {"screws": (1, 1), "rubber_bands": (1, 2)}
    assert r.success == pytest.approx(2 / 3)
    assert r.window_accuracy == pytest.approx(2 / 3)               # one window each


def test_compare_force_reads_the_mse_as_the_paper_does():
    """The paper's reading (per component) is the default, and it is half the vector form on
    the same predictions (the same session and the same seeded MLP)."""
    from fingertip.sim.paper_method import PAPER_MSE_PER_COMPONENT, compare_force

    assert PAPER_MSE_PER_COMPONENT
    per = compare_force(1, Realism.ideal(), ours=False)
    vec = compare_force(1, Realism.ideal(), ours=False, per_component=False)
    assert per.paper_mse_n2 == pytest.approx(vec.paper_mse_n2 / 2, rel=1e-9)
    assert 0 < per.paper_mse_n2 < 0.2
