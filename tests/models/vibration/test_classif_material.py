"""Material classifier on recordings of the virtual fingertip, made here with the physics.

Seven materials, twelve 1 s slides each at random speeds (10-40 mm/s) and normal forces
(0.5-2 N), written as 16-bit WAV files in a class-per-folder dataset at 44.1 kHz, and the
same slides resampled to 8 kHz. Evaluations are by recording (cross-validation: every
recording tested once by a model that never saw it).
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
import soundfile as sf
from scipy.signal import resample_poly

from fingertip.audio import FileSource
from fingertip.cli.classify import main as cli
from fingertip.models.vibration.classify import (
    DatasetError,
    ModelError,
    VibrationClassifier,
    load_folder,
    split_by_recording,
    stratified_folds,
)
from fingertip.models.vibration.features import FeatureError, as_recording, read_recording
from fingertip.models.vibration.candidates import CANDIDATES, DEFAULT_CANDIDATES
from fingertip.models.vibration.material import train_material
from fingertip.models.vibration.reliability import apply_temperature
from fingertip.sim.physics import PAPER_SEVEN, Slide, simulate

N_PER_CLASS = 12
CHANCE = 1 / len(PAPER_SEVEN)


def _write(root, rate: int, n: int = N_PER_CLASS, seconds: float = 1.0) -> None:
    for ci, m in enumerate(PAPER_SEVEN):
        (root / m).mkdir(parents=True, exist_ok=True)
        for k in range(n):
            rng = np.random.default_rng([0, ci, k])
            speed = float(np.exp(rng.uniform(np.log(10), np.log(40))))
            normal = float(np.exp(rng.uniform(np.log(0.5), np.log(2))))
            scene = Slide(m, speed_mm_s=speed, normal_n=normal, duration=seconds,
                          seed=int(rng.integers(1 << 30)))
            x = simulate(scene, seed=k).audio.samples.astype(np.float64)
            if rate != 44100:
                x = resample_poly(x, rate, 44100)
            sf.write(root / m / f"{m}_{k:02d}.wav", x, rate, subtype="PCM_16")


@pytest.fixture(scope="session")  # once a worker: the tests that train on it spread
def data(tmp_path_factory):
    root = tmp_path_factory.mktemp("materials")
    _write(root / "44k", 44100)
    _write(root / "8k", 8000)
    return root


@pytest.fixture(scope="module")
def trained(data, tmp_path_factory):
    """A 4-fold cross-validated model at 44.1 kHz (the exported one saw every recording)."""
    return train_material(data / "44k", tmp_path_factory.mktemp("model44"), folds=4)


def test_beats_chance_and_confuses_copper_tape_with_wax_paper(trained):
    ev = trained.evaluation
    w = ev.windows
    assert w.n == trained.report["summary"]["test_windows"]
    assert ev.recordings.n == len(PAPER_SEVEN) * N_PER_CLASS       # every recording tested
    assert w.accuracy > 5 * CHANCE                                   # chance: 14 %
    assert ev.recordings.accuracy > 5 * CHANCE
    assert set(w.recall) == set(PAPER_SEVEN) and min(w.recall.values()) > 0.3
    assert w.most_confused()[:2] == ("copper_tape", "wax_paper")     # as in the paper
    rep = json.loads((trained.out / "report.json").read_text())
    folds = rep["split"]["folds"]
    flat = [f for fold in folds for f in fold]
    assert len(flat) == len(set(flat)) == len(PAPER_SEVEN) * N_PER_CLASS
    for fold in folds:                                                 # stratified
        assert sorted(f.split("/")[0] for f in fold) == sorted(PAPER_SEVEN * 3)
    assert rep["evaluation"]["windows"]["most_confused"]["classes"] == ["copper_tape",
                                                                        "wax_paper"]
    assert (trained.out / "confusion.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert rep["features"]["f_hi"] == 7200 and rep["dataset"]["rates_hz"] == [44100]
    # Measured and reported; how fast is a benchmark's question (material_answer_latency_ms
    # in `make bench`), not a unit test's, which would flake on a busy machine.
    lat = rep["timing"]["latency_model_ms"]
    assert 0 < lat["p50"] <= lat["p90"] < float("inf")


def test_single_split_keeps_recordings_on_one_side(data, tmp_path):
    ds = load_folder(data / "44k")
    r = train_material(ds, tmp_path, seed=3, plot=False)
    split = r.report["split"]
    tested = set(split["test_recordings"])
    assert all(v == {"train": 9, "test": 3} for v in split["per_class"].values())
    assert len(tested) == 21
    # the evaluation saw exactly the windows of the test recordings
    clf = VibrationClassifier(r.model_path)
    n_test = sum(len(clf.classify(it.rec).predictions) for it in ds.items
                 if ds.rel(it) in tested)
    assert r.evaluation.windows.n == n_test
    assert r.evaluation.recordings.n == 21
    tr, te = split_by_recording(ds.labels, 0.25, seed=3)
    assert not set(tr) & set(te) and len(tr) + len(te) == len(ds.items)
    folds = stratified_folds(ds.labels, 4, seed=0)
    assert sorted(np.concatenate(folds).tolist()) == list(range(len(ds.items)))


def test_eight_khz_recordings(data, tmp_path):
    """The same slides at 8 kHz (resampled from 44.1 kHz): bands up to 3.6 kHz."""
    r = train_material(data / "8k", tmp_path, folds=4, plot=False)
    assert r.report["features"]["f_hi"] == 3600
    assert r.evaluation.windows.accuracy > 5 * CHANCE
    assert r.evaluation.windows.most_confused()[:2] == ("copper_tape", "wax_paper")


def test_a_model_runs_at_lower_rates_only_when_its_bands_fit(data, trained, tmp_path):
    rec8 = data / "8k" / "coarse_fabric" / "coarse_fabric_00.wav"
    with pytest.raises(FeatureError, match="--max-hz 3600"):
        VibrationClassifier(trained.model_path).classify(rec8)
    # trained at 44.1 kHz with bands capped at 3.6 kHz: it classifies 8 kHz recordings
    r = train_material(data / "44k", tmp_path, max_hz=3600, folds=1, seed=1, plot=False)
    clf = VibrationClassifier(r.model_path)
    test = r.report["split"]["test_recordings"]
    right = [clf.classify(data / "8k" / f).vote == f.split("/")[0] for f in test]
    assert np.mean(right) > 5 * CHANCE


def test_onnx_matches_float64_and_gain_does_not_matter(data, trained):
    clf = VibrationClassifier(trained.model_path, kind="material")
    assert clf.classes == sorted(PAPER_SEVEN)
    assert clf.architecture == trained.report["model"] in CANDIDATES
    rec = read_recording(data / "44k" / "tpu" / "tpu_03.wav")
    w = clf.pipeline.windows(rec)
    ref = apply_temperature(trained.model.forward(w.inputs.astype(np.float64)),
                            clf.temperature)
    out = clf.predict(w.inputs)
    assert out.dtype == np.float32 and np.max(np.abs(out - ref)) < 1e-4
    a = clf.classify(rec)
    rec.samples = rec.samples * 1e-3                                  # another sensor's gain
    b = clf.classify(rec)
    pa = np.array([[p.probabilities[c] for c in clf.classes] for p in a.predictions])
    pb = np.array([[p.probabilities[c] for c in clf.classes] for p in b.predictions])
    assert np.max(np.abs(pa - pb)) < 1e-3
    run = a.running()
    assert a.vote == b.vote == clf.classes[int(np.argmax(run[-1]))]
    assert np.allclose(run, pa)                  # a 1 s slide: every window starts at 0
    first = a.predictions[0]
    assert first.t_start == 0 and first.t_end == pytest.approx(0.25, abs=0.012)
    assert a.predictions[1].t_end - first.t_end == pytest.approx(0.1, abs=0.006)  # 10 Hz
    assert a.predictions[-1].t_end == pytest.approx(1.0, abs=0.012)  # the whole slide
    assert math.isfinite(first.level_db) and not first.clipped
    with pytest.raises(ModelError, match="not a shake model"):
        VibrationClassifier(trained.model_path, kind="shake")


def test_silence_clipping_and_short_recordings(data, trained):
    clf = VibrationClassifier(trained.model_path)
    rec = read_recording(data / "44k" / "coarse_fabric" / "coarse_fabric_02.wav")
    loud = as_recording(np.clip(rec.samples * 50, -1, 1), rec.rate, "clipped", 1.0)
    assert loud.clipped
    res = clf.classify(loud)
    assert all(p.clipped for p in res.predictions)
    silent = clf.classify(as_recording(np.zeros(44100), 44100, "silence", 1.0))
    assert all(p.level_db == -math.inf and not p.clipped for p in silent.predictions)
    assert all(math.isfinite(p.probability) for p in silent.predictions)
    short = as_recording(rec.samples[:int(0.3 * rec.rate)], rec.rate, "short", 1.0)
    two = clf.classify(short).predictions
    assert len(two) == 2 and two[-1].t_end == pytest.approx(0.3, abs=0.012)
    with pytest.raises(FeatureError, match="shorter than one window"):
        clf.classify(as_recording(rec.samples[:4410], rec.rate, "tiny", 1.0))


def test_live_stream_matches_the_file(data, trained):
    clf = VibrationClassifier(trained.model_path)
    path = data / "44k" / "expanded_plastic" / "expanded_plastic_05.wav"
    offline = clf.classify(path).predictions
    live = list(clf.stream(FileSource(path, blocksize=441)))
    assert abs(len(live) - len(offline)) <= 1
    n = min(len(live), len(offline))
    agree = np.mean([a.label == b.label for a, b in zip(live[:n], offline[:n], strict=True)])
    assert agree >= 0.8
    for a, b in zip(live[:n], offline[:n], strict=True):
        assert abs(a.t_end - b.t_end) <= 0.006 and a.host_time is not None
        assert max(abs(a.running[c] - b.running[c]) for c in clf.classes) < 0.2


def test_command_line(data, tmp_path, capsys, caplog):
    out = tmp_path / "m"
    assert cli(["train", "material", str(data / "8k"), "-o", str(out), "--folds", "2",
                "--mains-notch"]) == 0
    text = capsys.readouterr().out
    assert "2-fold cross-validation by recording" in text
    assert "candidates" in text and "baseline" in text and "chosen: " in text
    model = out / "material.onnx"
    assert VibrationClassifier(model).cfg.mains_notch  # the runtime notches as training did
    f = data / "8k" / "plush_fabric" / "plush_fabric_01.wav"
    assert cli(["classify", "material", str(model), str(f), "--json"]) == 0
    lines = [json.loads(v) for v in capsys.readouterr().out.splitlines()]
    assert lines[-1]["vote"] in PAPER_SEVEN and lines[0]["t_start"] == 0
    assert {"label", "probability", "level_db", "clipped"} <= set(lines[0])
    assert cli(["classify", "material", str(model), "--simulate", "coarse_fabric", "--fast",
                "--duration", "1.5"]) == 0
    assert "vote: " in capsys.readouterr().out
    assert cli(["classify", "material", str(model), str(f), "--decide-at", "0.5",
                "--json"]) == 0
    lines = [json.loads(v) for v in capsys.readouterr().out.splitlines()]
    d = lines[-1]["decision"]
    assert d["decided"] and d["label"] in PAPER_SEVEN and 0.2 < d["t"] <= 1.0
    assert max(lines[-2]["running"].values()) >= 0.5     # it stopped at the first answer
    assert all(max(v["running"].values()) < 0.5 for v in lines[:-2])
    with pytest.raises(SystemExit) as bad:
        cli(["classify", "material", str(model), str(f), "--decide-at", "1.5"])
    assert bad.value.code == 2
    assert cli(["classify", "shake", str(model), str(f)]) == 2
    assert "not a shake model" in caplog.text
    assert cli(["classify", "material", str(model)]) == 2
    assert cli(["classify", "material", str(model), "--port", "/dev/no-such-port"]) == 2
    assert "give the sound card with --audio" in caplog.text
    assert cli(["train", "material", str(tmp_path / "nothing")]) == 2
    assert "not a folder" in caplog.text


def test_bad_folders_and_csv_datasets(tmp_path):
    one = tmp_path / "one"
    (one / "a").mkdir(parents=True)
    noise = np.random.default_rng(1).normal(0, 0.1, (2, 8000))
    sf.write(one / "a" / "x.wav", noise[0], 8000)
    with pytest.raises(DatasetError, match="need at least 2"):
        load_folder(one)
    (one / "b").mkdir()
    sf.write(one / "b" / "y.wav", noise[1], 8000)
    with pytest.raises(DatasetError, match="nothing to test on"):
        train_material(one, tmp_path / "one_out")
    # silent, constant, NaN and clipped recordings are refused, the file named (issue 28)
    for x, why in ((np.zeros(8000), "silent"), (np.ones(8000) * 0.1, "constant"),
                   (np.where(np.arange(8000) == 9, np.nan, noise[1]), "NaN"),
                   (np.clip(noise[1] * 30, -1, 1), "clipped")):
        sf.write(one / "b" / "y.wav", x, 8000, subtype="FLOAT")
        with pytest.raises(DatasetError, match=f"y.wav.*{why}"):
            load_folder(one)
    csv = tmp_path / "csv"
    rng = np.random.default_rng(0)
    t = np.arange(4000) / 4000
    for cls, f0 in (("low", 300), ("high", 1200)):
        (csv / cls).mkdir(parents=True)
        for k in range(4):
            x = np.sin(2 * np.pi * f0 * (1 + 0.05 * k) * t) + 0.3 * rng.normal(size=len(t))
            (csv / cls / f"{k}.csv").write_text("\n".join(f"{v:.5f}" for v in x))
    with pytest.raises(DatasetError, match="fewer than two classes"):
        load_folder(csv)                                    # no rate anywhere: all skipped
    r = train_material(csv, tmp_path / "out", rate_hint=4000, folds=2, plot=False)
    assert r.report["dataset"]["rates_hz"] == [4000] and r.report["features"]["f_hi"] == 1800
    assert r.evaluation.windows.accuracy > 0.9


PNG = b"\x89PNG\r\n\x1a\n"


def test_short_recordings_at_low_rates_train_without_options(data, tmp_path):
    """1 s slides at 2.2 kHz and 0.3 s cuts at 44.1 kHz: windows, bands and step adapt;
    every candidate is reported with its accuracy by decision time and its cost."""
    low = tmp_path / "2k2"
    for p in (data / "8k").rglob("*.wav"):
        x, fs = sf.read(p)
        (low / p.parent.name).mkdir(parents=True, exist_ok=True)
        sf.write(low / p.parent.name / p.name, resample_poly(x, 11, 40), 2200,
                 subtype="PCM_16")
    r = train_material(low, tmp_path / "m2k2", folds=3)
    rep = r.report
    assert rep["features"]["f_hi"] == 990 and rep["setup"]["features"]["f_lo"] == 30
    # the CNN is cross-validated or skipped by its budget rule, with the reason, never both
    assert set(rep["candidates"]) | set(rep["candidates_skipped"]) == set(DEFAULT_CANDIDATES)
    assert not set(rep["candidates"]) & set(rep["candidates_skipped"])
    for c in rep["candidates"].values():
        assert set(c["accuracy_by_time"]) == {"0.25 s", "0.5 s", "1 s", "2 s", "whole"}
        assert c["accuracy_by_time"]["2 s"]["recordings"] == 0      # 1 s slides
        assert c["cost"]["parameters"] > 0 and c["cost"]["latency_model_ms"]["p50"] > 0
    assert rep["accuracy_by_time"]["whole"]["accuracy"] > 4 * CHANCE
    assert rep["model"] in rep["choice"] and 0 <= rep["calibration"]["ece"] <= 1
    assert [row["threshold"] for row in rep["decision_curve"]] == sorted(
        row["threshold"] for row in rep["decision_curve"])
    for name in ("decision.png", "reliability.png", "confusion.png"):
        assert (tmp_path / "m2k2" / name).read_bytes()[:8] == PNG

    knocks = tmp_path / "knocks"
    for p in (data / "44k").rglob("*_0[0-5].wav"):
        x, fs = sf.read(p)
        (knocks / p.parent.name).mkdir(parents=True, exist_ok=True)
        sf.write(knocks / p.parent.name / p.name, x[:int(0.3 * fs)], fs)
    k = train_material(knocks, tmp_path / "mk", folds=3, plot=False).report
    assert k["setup"]["first_window_s"] == pytest.approx(0.15, abs=0.01)
    assert k["setup"]["longest_window_s"] == pytest.approx(0.3, abs=0.01)
    assert k["setup"]["step_s"] <= 0.05 and "median recording" in k["setup"]["why"]["step"]
    assert k["accuracy_by_time"]["whole"]["recordings"] == len(PAPER_SEVEN) * 6
    assert k["accuracy_by_time"]["whole"]["accuracy"] > 3 * CHANCE


def test_unknown_answers_for_a_class_left_out(data):
    """Plush fabric left out of training: its slides look less like any trained class
    than known slides do (ROC AUC of the unknown score), and the rule that keeps 95 % of
    known answers calls some of them unknown."""
    from fingertip.models.vibration.bank import candidate_windows
    from fingertip.models.vibration.candidates import candidates
    from fingertip.models.vibration.cross_validation import unknown_auroc
    from fingertip.models.vibration.setup import choose_setup

    ds = load_folder(data / "8k")
    cand = candidates(choose_setup(ds), ("linear",))[0]
    cw = candidate_windows(cand, ds)
    u = unknown_auroc(cand, cw, ds, "plush_fabric", k=3)
    assert u["left_out_answers"] == 3 * N_PER_CLASS               # one per fold model
    assert u["known_recordings"] == N_PER_CLASS * (len(PAPER_SEVEN) - 1)
    assert u["auroc"] > 0.6
    assert u["known_answered_unknown"] <= 0.1
    assert u["left_out_answered_unknown"] > u["known_answered_unknown"]
