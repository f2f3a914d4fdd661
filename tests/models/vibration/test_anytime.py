"""Anytime decisions, logistic regression and calibration, on numbers made here (no audio):
growing windows, running probabilities, decisions, temperature scaling, ECE, ROC AUC, the
Gemm + Softmax export, and the setup chosen for short recordings and low rates."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from fingertip.models.vibration.anytime import (
    at_time,
    decide,
    growing_bounds,
    running,
    span_features,
    training_bounds,
)
from fingertip.models.vibration.setup import choose_setup
from fingertip.models.vibration.classify import Dataset, Labelled
from fingertip.models.vibration.features import FeatureConfig, as_recording
from fingertip.models.vibration.window_features import log_window, pooled
from fingertip.models.nets.linear import to_onnx, train_logistic
from fingertip.models.nets.mlp import OnnxModel
from fingertip.models.vibration.reliability import (
    apply_temperature,
    auroc,
    ece,
    fit_temperature,
    unknown_score,
)


def test_growing_windows_grow_then_slide_and_always_end_at_the_end():
    s, e = growing_bounds(50, frames=20, min_frames=5, step_frames=4.3)
    assert e[0] == 5 and e[-1] == 50 and np.all(np.diff(e) > 0)
    assert np.all(s[e <= 20] == 0) and np.all(e[e > 20] - s[e > 20] == 20)
    s, e = growing_bounds(5, 20, 5, 4.3)                          # exactly the first window
    assert s.tolist() == [0] and e.tolist() == [5]
    assert len(growing_bounds(4, 20, 5, 4.3)[0]) == 0             # too short: nothing
    s, e = training_bounds(100, 40, 5, 4.0)
    lengths = set((e - s).tolist())
    assert lengths == {5, 10, 20, 40} and s.min() == 0 and e.max() == 100
    s, e = training_bounds(7, 40, 5, 4.0)                          # shorter than the longest
    assert set((e - s).tolist()) == {5, 7}
    assert len(training_bounds(3, 40, 5, 4.0)[0]) == 0


def test_span_features_are_the_pooled_summary_and_gain_free():
    rng = np.random.default_rng(0)
    power = rng.gamma(2.0, 1.0, (30, 8)).astype(np.float32)
    s, e = np.array([0, 10]), np.array([12, 30])
    f = span_features(power, s, e, -80.0, ("mean", "std", "flux"))
    assert f.shape == (2, 24)
    assert np.allclose(f[1], pooled(log_window(power[10:30], -80.0)), atol=1e-5)
    assert np.allclose(span_features(power * 1e4, s, e, -80.0), f, atol=1e-3)
    one = span_features(power, np.array([0]), np.array([1]), -80.0)   # one frame: no spread
    assert np.all(one[0, 8:] == 0)


def test_running_probabilities_and_decisions():
    p = np.array([[0.6, 0.4], [0.7, 0.3], [0.2, 0.8], [0.4, 0.6]])
    grow = np.array([True, True, False, False])
    run = running(p, grow)
    assert np.allclose(run[:2], p[:2]) and np.allclose(run[2], p[2])
    assert np.allclose(run[3], (p[2] + p[3]) / 2)
    assert np.allclose(running(p)[-1], p.mean(axis=0))
    t = np.array([0.25, 0.35, 0.45, 0.55])
    d = decide(run, t, ["a", "b"], 0.65)
    assert d.decided and d.label == "a" and d.t == 0.35 and d.probability == pytest.approx(0.7)
    d = decide(run, t, ["a", "b"], 0.9)
    assert not d.decided and d.label == "b" and d.t == 0.55
    assert decide(np.zeros((0, 2)), np.zeros(0), ["a", "b"], 0.5).label is None
    with pytest.raises(ValueError):
        decide(run, t, ["a", "b"], 0.0)
    assert at_time(run, t, 0.2) is None and np.allclose(at_time(run, t, 0.4), run[1])
    assert np.allclose(at_time(run, t, None), run[-1])


def test_temperature_ece_and_auroc():
    rng = np.random.default_rng(1)
    logits = rng.normal(0, 3, (4000, 4))
    truth = np.array([rng.choice(4, p=q) for q in apply_temperature(
        np.exp(logits) / np.exp(logits).sum(1, keepdims=True), 1.0)])
    over = apply_temperature(np.exp(logits) / np.exp(logits).sum(1, keepdims=True), 0.5)
    t = fit_temperature(over, truth)
    assert t == pytest.approx(2.0, rel=0.15)              # undoes the over-confidence
    fixed = apply_temperature(over, t)
    e_over = ece(over.max(1), over.argmax(1) == truth)
    e_fixed = ece(fixed.max(1), fixed.argmax(1) == truth)
    assert e_fixed < 0.03 < e_over
    assert ece(np.ones(3), np.ones(3, bool)) == 0 and ece(np.zeros(0), np.zeros(0)) == 0
    assert fit_temperature(np.zeros((0, 3)), np.zeros(0)) == 1.0
    assert auroc([2, 3], [0, 1]) == 1 and auroc([0], [1]) == 0 and auroc([1], [1]) == 0.5
    assert math.isnan(auroc([], [1]))
    assert np.allclose(unknown_score(np.array([[0.9, 0.1], [0.5, 0.5]])), [0.1, 0.5])


def test_logistic_regression_weights_recordings_and_exports_with_its_temperature(tmp_path):
    rng = np.random.default_rng(2)
    centres = rng.normal(0, 1, (3, 5)) * 3
    y = np.repeat(np.arange(3), 40)
    x = centres[y] + rng.normal(0, 1, (120, 5))
    x[:, 4] = 7.0                                               # a constant feature
    g = np.arange(120) // 4                                     # 4 windows per recording
    m = train_logistic(x, y, classes=["a", "b", "c"], groups=g)
    assert np.mean(m.forward(x).argmax(1) == y) > 0.95 and m.l2 > 0
    path = to_onnx(m, tmp_path / "lr.onnx", temperature=0.5, metadata={"x": "1"})
    onnx = OnnxModel(path)
    assert onnx.metadata["x"] == "1"
    assert np.allclose(onnx(x.astype(np.float32)), apply_temperature(m.forward(x), 0.5),
                       atol=1e-5)
    with pytest.raises(ValueError, match="NaN"):
        train_logistic(np.full((4, 2), np.nan), np.array([0, 1, 0, 1]), classes=["a", "b"])
    with pytest.raises(ValueError, match="labels"):
        train_logistic(np.zeros((2, 2)), np.array([0, 2]), classes=["a", "b"])
    few = train_logistic(x[:6], np.array([0, 1, 2, 0, 1, 2]), classes=["a", "b", "c"])
    assert np.all(np.isfinite(few.w))                            # too few to choose l2


def _dataset(seconds: list[float], rate: float) -> Dataset:
    items = [Labelled(Path(f"{i}.wav"), "ab"[i % 2], i % 2,
                      as_recording(np.zeros(int(s * rate)), rate)) for i, s in enumerate(seconds)]
    return Dataset(Path("."), ["a", "b"], items)


def test_setup_adapts_to_short_recordings_and_low_rates():
    knocks = choose_setup(_dataset([0.3] * 6, 44100))
    assert knocks.cfg.f_hi == 7200 and knocks.cfg.f_lo == 100
    assert knocks.longest_s == pytest.approx(0.3) and knocks.first_s == pytest.approx(0.15)
    assert knocks.step_s == pytest.approx(0.03)
    assert knocks.frames(knocks.first_s) >= 3
    slides = choose_setup(_dataset([1.0] * 6, 2200))
    assert slides.cfg.f_hi == 990 and slides.cfg.f_lo == 30
    assert (slides.first_s, slides.longest_s, slides.step_s) == (0.25, 1.0, 0.1)
    long = choose_setup(_dataset([30.0] * 6, 8000))
    assert long.longest_s == 2.0 and long.cfg.f_lo == 50
    given = choose_setup(_dataset([1.0] * 6, 8000), FeatureConfig(f_lo=200.0),
                         window_s=0.5, step_s=0.05)
    assert given.cfg.f_lo == 200 and given.longest_s == 0.5 and given.step_s == 0.05
    assert set(given.to_dict()["why"]) >= {"f_hi", "longest_window", "first_window", "step"}
