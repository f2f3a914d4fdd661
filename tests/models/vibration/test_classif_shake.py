"""Shake classifiers (numpy ResNet CNN and MLP) on box shakes of the virtual fingertip."""
from __future__ import annotations

import json

import numpy as np
import pytest
import soundfile as sf

from fingertip.audio import FileSource
from fingertip.models.nets.mlp import OnnxModel
from fingertip.cli.classify import main as cli
from fingertip.models.vibration.classify import (
    DatasetError,
    Evaluation,
    ModelEvaluation,
    VibrationClassifier,
    majority_vote,
    paired_difference,
)
from fingertip.models.nets.cnn import CnnSpec, SmallResNet, train_cnn
from fingertip.models.vibration.shake import ModelResult, compare, train_shake
from fingertip.sim.physics import BOX_CONTENTS, BoxShake, simulate

N_PER_CLASS = 6
SECONDS = 3.0


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    root = tmp_path_factory.mktemp("shakes")
    for ci, c in enumerate(BOX_CONTENTS):
        (root / c).mkdir()
        for k in range(N_PER_CLASS):
            rng = np.random.default_rng([1, ci, k])
            scene = BoxShake(c, grip_n=float(rng.uniform(1.0, 2.0)), duration=SECONDS,
                             seed=int(rng.integers(1 << 30)))
            x = simulate(scene, seed=k).audio.samples
            sf.write(root / c / f"{c}_{k:02d}.wav", x, 44100, subtype="PCM_16")
    return root


@pytest.fixture(scope="module")
def trained(data, tmp_path_factory):
    return train_shake(data, tmp_path_factory.mktemp("shake_model"), cnn_epochs=12,
                       train_step_s=0.25)


def test_cnn_and_mlp_classify_shakes_by_majority_vote(trained):
    assert set(trained.results) == {"cnn", "mlp"}
    for name, r in trained.results.items():
        ev = r.evaluation
        assert ev.recordings.n == 2 * len(BOX_CONTENTS)          # 2 held-out shakes each
        assert ev.recordings.accuracy == 1.0, name                # majority vote per shake
        assert ev.windows.accuracy > 0.9, name                    # 10 Hz predictions
        assert ev.windows.n == ev.recordings.n * 20               # (3 s - 1.02 s) / 0.1 + 1
    rep = json.loads((trained.out / "report.json").read_text())
    split = rep["split"]
    assert all(v == {"train": 3, "test": 2, "validation": 1}
               for v in split["per_class"].values())
    val, test = set(split["validation_recordings"]), set(split["test_recordings"])
    assert not val & test and len(test) == 6
    assert rep["window"]["frames"] == 86 and rep["window"]["seconds"] == pytest.approx(1.0)
    for name in ("cnn", "mlp"):
        assert (trained.out / f"confusion_{name}.png").read_bytes()[:4] == b"\x89PNG"
        assert (trained.out / f"shake_{name}.onnx").is_file()


@pytest.mark.realtime
def test_costs_are_measured_side_by_side(trained):
    c, m = trained.results["cnn"].cost, trained.results["mlp"].cost
    assert c["parameters"] > 5 * m["parameters"] and c["multiply_adds"] > 100 * m[
        "multiply_adds"]
    for cost in (c, m):
        assert 0 < cost["latency_model_ms"]["p50"] < 50
        assert 0 < cost["latency_window_audio_ms"]["p50"] < 200
        assert cost["train_s"] > 0 and cost["train_windows"] > 0
    table = (trained.out / "report.md").read_text()
    assert "| parameters |" in table and "Verdict: CNN" in table
    assert trained.verdict.startswith("CNN not worth it")          # equal accuracy here
    assert "x the MLP's model latency" in trained.verdict


def test_onnx_models_match_their_float64_reference(trained, data):
    cnn_clf = VibrationClassifier(trained.results["cnn"].path, kind="shake")
    assert cnn_clf.architecture == "cnn" and cnn_clf.spec.input == "spectrogram"
    assert cnn_clf.spec.frames == 86 and cnn_clf.spec.step_s == 0.1
    res = cnn_clf.classify(data / "screws" / "screws_00.wav")
    assert res.vote == "screws" and len(res.predictions) == 20
    assert res.predictions[1].t_start == pytest.approx(0.1, abs=0.006)
    mlp_clf = VibrationClassifier(trained.results["mlp"].path, kind="shake")
    assert mlp_clf.spec.input == "pooled"
    assert mlp_clf.classify(data / "empty" / "empty_05.wav").vote == "empty"


def test_cnn_gradients_and_onnx_export(tmp_path):
    spec = CnnSpec(frames=12, bands=10, channels=(3, 4, 5), head=6, n_classes=3)
    m = SmallResNet.init(spec, seed=1, classes=["a", "b", "c"])
    rng = np.random.default_rng(0)
    m.params = {k: v + rng.normal(0, 0.3, v.shape) for k, v in m.params.items()}
    m.x_mean, m.x_std = -20.0, 7.0
    x = rng.normal(-20, 7, (4, 12, 10))
    y = np.array([0, 1, 2, 1])

    def loss(params):
        p = m.forward(x, np.float64, params=params)
        return -np.log(p[np.arange(4), y]).sum() / 4

    prm = {k: v.copy() for k, v in m.params.items()}
    cache: dict = {}
    p = m.forward(x, np.float64, cache=cache, params=prm)
    grads = m.backward(cache, (p - np.eye(3)[y]) / 4, prm)
    assert set(grads) == set(prm)
    for k in prm:
        for _ in range(3):
            idx = tuple(int(rng.integers(0, s)) for s in prm[k].shape)
            old = prm[k][idx]
            prm[k][idx] = old + 1e-6
            lp = loss(prm)
            prm[k][idx] = old - 1e-6
            lm = loss(prm)
            prm[k][idx] = old
            num = (lp - lm) / 2e-6
            assert abs(num - grads[k][idx]) <= 1e-6 * max(1.0, abs(num)), k
    path = m.to_onnx(tmp_path / "c.onnx", metadata={"note": "test"})
    run = OnnxModel(path)
    for batch in (x[:1], x):
        out = run(batch.astype(np.float32))
        assert out.shape == (len(batch), 3)
        assert np.max(np.abs(out - m.forward(batch))) < 1e-5
    assert run.metadata["note"] == "test" and json.loads(run.metadata["n_params"]) == \
        m.n_params
    with pytest.raises(ValueError, match="takes windows"):
        m.forward(np.zeros((1, 11, 10)))


def test_cnn_training_refuses_bad_inputs():
    with pytest.raises(ValueError, match="NaN"):
        train_cnn(np.full((4, 8, 8), np.nan), np.zeros(4, int), classes=["a", "b"])
    with pytest.raises(ValueError, match="labels"):
        train_cnn(np.zeros((4, 8, 8)), np.array([0, 1, 2, 0]), classes=["a", "b"])


def test_live_stream_and_command_line(trained, data, capsys):
    clf = VibrationClassifier(trained.results["cnn"].path)
    path = data / "rubber_bands" / "rubber_bands_02.wav"
    live = list(clf.stream(FileSource(path)))
    assert len(live) in (19, 20, 21)
    probs = np.array([[p.probabilities[c] for c in clf.classes] for p in live])
    assert clf.classes[majority_vote(probs)] == "rubber_bands"
    model = str(trained.results["mlp"].path)
    assert cli(["classify", "shake", model, "--simulate", "screws", "--fast"]) == 0
    out = capsys.readouterr().out
    assert out.strip().splitlines()[-1].startswith("vote: screws")
    assert cli(["classify", "shake", model, "--simulate", "copper_tape", "--fast"]) == 2


def test_cli_trains_one_model(data, tmp_path, capsys):
    assert cli(["train", "shake", str(data), "-o", str(tmp_path), "--model", "mlp"]) == 0
    out = capsys.readouterr().out
    assert "MLP:" in out and "only one model" in out
    assert (tmp_path / "shake_mlp.onnx").is_file() and not (tmp_path / "shake_cnn.onnx").exists()


def test_too_short_shakes_are_refused(tmp_path):
    for c in ("a", "b"):
        (tmp_path / c).mkdir()
        for k in range(3):
            # noise, not silence: a silent recording is refused before its length
            noise = np.random.default_rng(k).normal(0, 0.1, 8000)
            sf.write(tmp_path / c / f"{k}.wav", noise, 16000)
    with pytest.raises(DatasetError, match="1.0 s or more"):
        train_shake(tmp_path, tmp_path / "out", models=("mlp",))


def test_majority_vote_and_the_verdict_rule():
    p = np.array([[0.6, 0.4], [0.4, 0.6], [0.9, 0.1], [0.45, 0.55]])
    assert majority_vote(p) == 0                 # 2-2 tie: the higher summed probability
    with pytest.raises(ValueError):
        majority_vote(np.zeros((0, 2)))

    def ev(acc: dict[int, float]) -> ModelEvaluation:
        e = Evaluation(["a", "b"], np.array([[5, 0], [0, 5]]))
        return ModelEvaluation(e, e, acc)

    cost = {"latency_model_ms": {"p50": 1.0}, "latency_window_audio_ms": {"p50": 3.0},
            "train_s": 10.0, "parameters": 1000}
    cheap = dict(cost, latency_model_ms={"p50": 0.01}, train_s=1.0, parameters=100)
    base = {i: 0.8 + 0.01 * (i % 3) for i in range(10)}
    better = {i: v + 0.1 + 0.01 * (i % 2) for i, v in base.items()}
    d, se, n = paired_difference(ev(better), ev(base))
    assert d == pytest.approx(0.105) and se < 0.01 and n == 10
    res = {"cnn": ModelResult("cnn", None, ev(better), cost),
           "mlp": ModelResult("mlp", None, ev(base), cheap)}
    assert compare(res).startswith("CNN worth it")
    res["cnn"] = ModelResult("cnn", None, ev(base), cost)
    assert compare(res).startswith("CNN not worth it here")
    assert "100x the MLP's model latency" in compare(res)
