"""The paper's methods on virtual units (studies/paper_method.py): splits, the MSE's
reading, rest readings, the paper's models and votes."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fingertip.sim.physics import Realism, VirtualStrainSensor
from fingertip.sim.device.calibration_rig import calibration_sweep
from studies.paper_method import (
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
    from studies.paper_method import PAPER_MSE_PER_COMPONENT, compare_force

    assert PAPER_MSE_PER_COMPONENT
    per = compare_force(1, Realism.ideal(), ours=False)
    vec = compare_force(1, Realism.ideal(), ours=False, per_component=False)
    assert per.paper_mse_n2 == pytest.approx(vec.paper_mse_n2 / 2, rel=1e-9)
    assert 0 < per.paper_mse_n2 < 0.2
