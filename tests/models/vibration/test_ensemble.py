"""The ensemble candidate: members reading their own columns of one spectrogram (log bands
and the baseline's linear bins), combined by a normalised geometric mean, exported as one
ONNX graph that matches the float64 reference; chosen by the cross-validation like any other
candidate."""
from __future__ import annotations

import numpy as np
import pytest

from fingertip.models.nets.linear import train_logistic
from fingertip.models.nets.mlp import OnnxModel, train_mlp
from fingertip.models.vibration.candidates import baseline_bins, candidates
from fingertip.models.vibration.setup import choose_setup
from fingertip.models.vibration.classify import FeaturePipeline, VibrationClassifier, load_folder
from fingertip.models.vibration.ensemble import Ensemble, Member, to_onnx
from fingertip.models.vibration.features import (
    FeatureConfig,
    FeatureError,
    band_matrix,
    read_recording,
)
from fingertip.models.vibration.material import train_material
from tests.models.vibration.band_noise import write_band_noise

RATE = 8000


def _members(rng, d=12, k=3):
    x = rng.standard_normal((120, d)) * rng.uniform(0.1, 5, d) + rng.uniform(-3, 3, d)
    y = rng.integers(0, k, 120)
    x[np.arange(120), y] += 2.0  # something to learn
    classes = [f"c{i}" for i in range(k)]
    a, b = np.arange(0, 5), np.r_[3:9, 11]
    lin = train_logistic(x[:, a], y, classes=classes, l2=1e-2)
    mlp = train_mlp(x[:, b], y, hidden=(8,), task="classification", classes=classes,
                    epochs=20, seed=1)
    return x, Ensemble([Member(lin, a), Member(mlp, b)], d, classes)


def test_onnx_graph_matches_the_float64_reference_with_its_temperature(tmp_path):
    rng = np.random.default_rng(0)
    x, ens = _members(rng)
    for t in (1.0, 2.5):
        m = OnnxModel(to_onnx(ens, tmp_path / f"e{t}.onnx", temperature=t))
        want = ens.forward(x)
        if t != 1.0:  # the temperature divides the combined log-probabilities
            lp = ens.log_probs(x) / t
            want = np.exp(lp - lp.max(1, keepdims=True))
            want /= want.sum(1, keepdims=True)
        got = m(x.astype(np.float32))
        assert got.shape == (len(x), 3)
        np.testing.assert_allclose(got, want, atol=2e-5)
        assert m.n_features == 12  # the unread column 9 and 10 are still inputs
    # the combination is the normalised geometric mean of the members' probabilities
    p = [m.model.forward(x[:, m.columns]) for m in ens.members]
    g = np.sqrt(p[0] * p[1])
    np.testing.assert_allclose(ens.forward(x), g / g.sum(1, keepdims=True), atol=1e-12)
    with pytest.raises(ValueError, match="temperature"):
        to_onnx(ens, tmp_path / "bad.onnx", temperature=0.0)


def test_linear_bins_follow_the_bands_in_one_spectrogram():
    cfg = FeatureConfig(f_lo=50.0, f_hi=3600.0, linear_bins=20)
    assert cfg.total_bands == 32 + 20
    freqs = np.fft.rfftfreq(512, 1 / 16000)
    w = cfg.band_weights(freqs)
    assert w.shape == (len(freqs), 52)
    np.testing.assert_array_equal(w[:, :32], band_matrix(freqs, cfg.band_edges()))
    lin = FeatureConfig(f_lo=50.0, f_hi=3600.0, scale="linear", n_bands=20)
    np.testing.assert_array_equal(w[:, 32:], band_matrix(freqs, lin.band_edges()))
    # models written before the field load with none; nonsense is refused
    d = FeatureConfig(f_hi=3600.0).to_dict()
    del d["linear_bins"]
    assert FeatureConfig.from_dict(d).linear_bins == 0
    for bad in (2, 300, -1):
        with pytest.raises(FeatureError, match="linear_bins"):
            FeatureConfig(linear_bins=bad)


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """Three classes of noise in overlapping bands, 1 s each, any gain."""
    return write_band_noise(tmp_path_factory.mktemp("three"),
                            {"low": (200, 700), "mid": (500, 1500), "high": (1200, 3000)},
                            rate=RATE, seed=3)


def test_members_read_the_baseline_and_log_band_columns(folder):
    """The ensemble's pipeline holds the linear candidate's and the baseline's features
    column for column (each view normalised by its own mean power, as on its own)."""
    ds = load_folder(folder)
    setup = choose_setup(ds)
    c = {x.name: x for x in candidates(setup, ("baseline", "linear", "ensemble"))}
    rec = ds.items[0].rec
    nb, nl = setup.cfg.n_bands, baseline_bins(setup.cfg)
    assert c["ensemble"].pipe.cfg.linear_bins == nl
    for training in (False, True):
        e = c["ensemble"].pipe.windows(rec, training).inputs
        total = nb + nl
        assert e.shape[1] == 3 * total
        for name, cols in (("linear", np.r_[0:nb, total:total + nb]),
                           ("baseline", np.r_[nb:total, total + nb:2 * total])):
            np.testing.assert_allclose(e[:, cols], c[name].pipe.windows(rec, training).inputs,
                                       atol=1e-3)


def test_the_ensemble_is_trained_exported_and_run_like_any_candidate(folder, tmp_path):
    r = train_material(folder, tmp_path / "m", folds=3, plot=False, models=("ensemble",))
    rep = r.report
    assert rep["model"] == "ensemble"
    assert rep["features"]["linear_bins"] == baseline_bins(choose_setup(
        load_folder(folder)).cfg)
    assert rep["onnx_max_abs_diff_vs_float64"] < 1e-4
    assert rep["accuracy_by_time"]["whole"]["accuracy"] >= 0.9
    clf = VibrationClassifier(r.model_path)
    assert isinstance(clf.pipeline, FeaturePipeline) and clf.cfg.linear_bins > 0
    res = clf.classify(read_recording(next((folder / "high").glob("*.wav"))))
    assert res.predictions and res.vote == "high"
    # chosen among the others by the same rule: cheapest of the tied
    r2 = train_material(folder, tmp_path / "m2", folds=3, plot=False,
                        models=("linear", "ensemble"))
    assert set(r2.report["candidates"]) == {"linear", "ensemble"}
    acc = {k: v["mean_accuracy"] for k, v in r2.report["candidates"].items()}
    ens = r2.report["candidates"]["ensemble"]
    if ens.get("stopped"):  # it could no longer exceed the linear candidate by the tie
        assert r2.report["model"] == "linear"
        assert ens["mean_accuracy_at_most"] < acc["linear"] + 0.005
    else:
        assert r2.report["model"] == ("linear" if acc["linear"] >= acc["ensemble"] - 0.005
                                      else "ensemble")
