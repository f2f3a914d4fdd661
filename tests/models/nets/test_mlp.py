"""The shared MLP: training converges, ONNX reproduces the float64 reference in float32."""
from __future__ import annotations

import numpy as np
import pytest

from fingertip.models.nets.mlp import OnnxModel, to_onnx, train_mlp


def test_regression_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    x = rng.normal(0, 1e5, (600, 4)) + 3e5   # raw counts: large offsets and scales
    w = rng.normal(size=(4, 2)) * 1e-5
    y = x @ w + 0.3 * np.sin(x[:, :2] * 1e-5)
    m = train_mlp(x, y, hidden=(16, 16), epochs=200, seed=1)
    ref = m.forward(x)
    assert np.sqrt(np.mean((ref - y) ** 2)) < 0.1 * y.std()
    path = to_onnx(m, tmp_path / "f.onnx", metadata={"unit": "N"})
    run = OnnxModel(path)
    out = run(x)
    # float32 inference against the float64 reference: relative to the output scale.
    assert np.max(np.abs(out - ref)) < 1e-4 * np.abs(ref).max()
    assert run(x[0]).shape == (2,)
    assert run.metadata["unit"] == "N" and run.metadata["task"] == "regression"
    with pytest.raises(ValueError, match="takes 4 features"):
        run(np.zeros(3))


def test_folded_normalisation_holds_at_the_24_bit_extremes(tmp_path):
    """The export folds the input normalisation and the output scaling into the first and
    last layers (fewer nodes per call); float32 must still match the float64 reference,
    including untared counts (offsets of 100 standard deviations) and full-scale inputs."""
    import onnx  # the train extra, part of the dev install
    rng = np.random.default_rng(3)
    x = rng.normal(0, 2e4, (800, 4)) + 2e6          # untared: mean / std = 100
    y = np.stack([x[:, 0] - x[:, 2], x[:, 1] - x[:, 3]], axis=1) * 1e-5
    m = train_mlp(x, y, hidden=(16, 16), epochs=100, seed=2)
    path = to_onnx(m, tmp_path / "f.onnx")
    ops = [n.op_type for n in onnx.load(str(path)).graph.node]
    assert ops == ["MatMul", "Add", "Relu", "MatMul", "Add", "Relu", "MatMul", "Add"]
    run = OnnxModel(path)
    probe = np.concatenate([x[:50], np.full((1, 4), 8_388_607.0), np.full((1, 4), -8_388_608.0),
                            np.zeros((1, 4))])
    ref, out = m.forward(probe), run(probe)
    scale = np.abs(m.forward(x)).max()
    assert np.all(np.isfinite(out))
    assert np.max(np.abs(out[:50] - ref[:50])) < 1e-4 * scale
    # Far outside the training range the outputs are large; float32 keeps them to 1e-5.
    assert np.max(np.abs(out[50:] - ref[50:]) / np.maximum(np.abs(ref[50:]), scale)) < 1e-5


def test_classification_round_trip(tmp_path):
    rng = np.random.default_rng(1)
    centres = rng.normal(0, 3, (3, 5))
    labels = rng.integers(0, 3, 900)
    x = centres[labels] + rng.normal(0, 1, (900, 5))
    m = train_mlp(x, labels, hidden=(16,), task="classification", classes=["a", "b", "c"],
                  epochs=100)
    p = OnnxModel(to_onnx(m, tmp_path / "c.onnx"))(x)
    assert np.allclose(p.sum(axis=1), 1, atol=1e-5)
    assert np.mean(p.argmax(axis=1) == labels) > 0.9


def test_bad_inputs_are_refused(tmp_path):
    with pytest.raises(ValueError, match="NaN"):
        train_mlp(np.array([[0.0], [np.nan]] * 10), np.zeros(20))
    with pytest.raises(ValueError, match="shape"):
        train_mlp(np.zeros(10), np.zeros(10))
    with pytest.raises(FileNotFoundError):
        OnnxModel(tmp_path / "missing.onnx")
    (tmp_path / "bad.onnx").write_bytes(b"not a model")
    with pytest.raises(ValueError, match="not a usable ONNX model"):
        OnnxModel(tmp_path / "bad.onnx")
