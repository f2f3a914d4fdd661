"""Material classification from sliding vibrations: ``fingertip train material FOLDER``.

The paper slides the fingernail 16 mm over seven materials, turns the contact microphone's
signal into STFT spectrograms and trains an MLP (95.49 %, copper tape and wax paper confused
most). Here:

- windows of 0.5 s (43 frames of 11.6 ms) every 0.1 s (predictions at 10 Hz); a recording
  shorter than one window but longer than 0.25 s gives one shorter window (the paper's
  slides last 0.4-1.6 s);
- each window -> gain-free log band spectrogram -> its mean, standard deviation and mean
  frame-to-frame change per band (:func:`~fingertip.models.features.pooled`, 96 numbers);
- an MLP (:func:`~fingertip.models.mlp.train_mlp`, numpy) -> ONNX;
- evaluation split by recording (stratified), accuracy, per-class recall and precision,
  per window and per recording (majority vote), confusion-matrix PNG, written next to the
  model in the output folder (``material.onnx``, ``report.json``, ``confusion.png``).
"""
from __future__ import annotations

import json
import logging
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .classify import (
    Dataset,
    DatasetError,
    FeaturePipeline,
    ModelEvaluation,
    WindowSpec,
    dataset_summary,
    dataset_windows,
    evaluate_model,
    json_safe,
    latency_ms,
    load_folder,
    merge_evaluations,
    model_metadata,
    plot_confusion,
    require_test_set,
    split_by_recording,
    split_report,
    stack,
    stratified_folds,
)
from .features import FeatureConfig
from .mlp import MLP

log = logging.getLogger(__name__)

WINDOW_S = 0.5
STEP_S = 0.1
MIN_S = 0.25
HIDDEN = (32,)
MODEL_FILE = "material.onnx"
REPORT_FILE = "report.json"
CONFUSION_FILE = "confusion.png"


@dataclass
class TrainResult:
    out: Path
    model_path: Path
    evaluation: ModelEvaluation
    report: dict
    files: list[Path] = field(default_factory=list)
    model: MLP | None = None
    """The trained MLP (float64 reference of the exported ONNX graph)."""


def material_spec(cfg: FeatureConfig, window_s: float = WINDOW_S, step_s: float = STEP_S
                  ) -> WindowSpec:
    return WindowSpec(cfg.frames_for(window_s), step_s, "pooled",
                      min_frames=cfg.frames_for(min(MIN_S, window_s)))


def train_material(folder: str | os.PathLike | Dataset, out: str | os.PathLike, *,
                   window_s: float = WINDOW_S, step_s: float = STEP_S,
                   hidden: tuple[int, ...] = HIDDEN, test_fraction: float = 0.25,
                   seed: int = 0, rate_hint: float | None = None, max_hz: float | None = None,
                   epochs: int = 300, folds: int = 1, features: FeatureConfig | None = None,
                   kind: str = "material", plot: bool = True) -> TrainResult:
    """Train and evaluate a material classifier on a class-per-sub-folder dataset.

    ``out``: output folder (created). ``rate_hint``: the rate of CSV files that do not state
    theirs. ``max_hz``: cap the bands (so that the model also runs on recordings at
    ``max_hz / 0.45`` Hz or more). ``folds`` > 1: k-fold cross-validation by recording
    (every recording tested once by a model that never saw it; the exported model is then
    trained on all of them) instead of one split. Returns the evaluation; writes the ONNX
    model, a JSON report (dataset, split, accuracy, recall, precision, confusion matrices,
    timings) and a confusion-matrix PNG.
    """
    t_all = time.perf_counter()
    ds = folder if isinstance(folder, Dataset) else load_folder(folder, rate_hint=rate_hint)
    cfg = (features or FeatureConfig()).for_rates(ds.rates, max_hz)
    spec = material_spec(cfg, window_s, step_s)
    pipe = FeaturePipeline(cfg, spec)
    t0 = time.perf_counter()
    windows, short = dataset_windows(ds, pipe)
    t_features = time.perf_counter() - t0
    if short:
        log.warning("%d recording(s) shorter than %.2f s give no window: %s", len(short),
                    MIN_S, ", ".join(short[:5]) + (" ..." if len(short) > 5 else ""))
    labels = ds.labels
    from .cnn import blas_threads
    from .mlp import to_onnx, train_mlp

    def fit(idx: np.ndarray):
        x, y, _ = stack(windows, labels, idx)
        if not len(x):
            raise DatasetError("no training windows (recordings too short?)")
        if len(np.unique(y)) < len(ds.classes):
            raise DatasetError("some class has no training window (recordings too short?)")
        with blas_threads(1):
            return train_mlp(x, y, hidden=hidden, task="classification", classes=ds.classes,
                             epochs=epochs, seed=seed), x

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    if folds > 1:
        tests = stratified_folds(labels, folds, seed)
        parts = []
        for te in tests:
            m, _ = fit(np.setdiff1d(np.arange(len(labels)), te))
            parts.append(evaluate_model(m.forward, windows, labels, te, ds.classes))
        evaluation = merge_evaluations(parts)
        t_cv = time.perf_counter() - t0
        train_idx = np.arange(len(labels))
        t0 = time.perf_counter()
        mlp, x = fit(train_idx)
        split = {"by": "recording", "cross_validation_folds": folds,
                 "per_class": {c: {"recordings": n} for c, n in ds.counts().items()},
                 "folds": [[ds.rel(ds.items[i]) for i in te] for te in tests],
                 "exported_model": "trained on every recording after the cross-validation"}
    else:
        t_cv = 0.0
        train_idx, test_idx = split_by_recording(labels, test_fraction, seed)
        require_test_set(test_idx)
        mlp, x = fit(train_idx)
        evaluation = evaluate_model(mlp.forward, windows, labels, test_idx, ds.classes)
        split = split_report(ds, train_idx, test_idx)
    t_train = time.perf_counter() - t0
    ev = evaluation.windows
    summary = {"accuracy": ev.accuracy, "recording_accuracy": evaluation.recordings.accuracy,
               "test_windows": ev.n, "test_recordings": evaluation.recordings.n,
               "train_windows": int(len(x)), "folds": folds}
    meta = model_metadata(kind, cfg, spec, ds.classes, model="mlp",
                          evaluation=summary, trained_rates_hz=ds.rates)
    model_path = to_onnx(mlp, out / (f"{kind}.onnx" if kind != "material" else MODEL_FILE),
                         metadata=meta)
    # Latency: one window of audio -> prediction, and the model alone.
    from .classify import VibrationClassifier
    from .features import as_recording

    clf = VibrationClassifier(model_path)
    probe = as_recording(np.random.default_rng(0).normal(0, 0.05, int(round(
        max(1.0, pipe.span_s()) * 44100))), 44100, "latency probe", full_scale=1.0)
    one = clf.pipeline.windows(probe).inputs[:1]
    lat_model = latency_ms(lambda: clf.predict(one))
    lat_total = latency_ms(lambda: clf.classify(probe), repeats=50)
    onnx_out = clf.predict(x[:256])
    ref = mlp.forward(x[:256])
    report = {
        "kind": kind, "model": "mlp", "model_file": model_path.name,
        "dataset": dataset_summary(ds), "short_recordings": short,
        "features": cfg.to_dict(),
        "window": {"seconds": window_s, "frames": spec.frames, "step_s": step_s,
                   "min_frames": spec.min_frames},
        "split": split, "seed": seed,
        "test_fraction": test_fraction if folds <= 1 else None,
        "mlp": {"hidden": list(hidden), "parameters": mlp.n_params,
                "inputs": int(x.shape[1])},
        "evaluation": evaluation.to_dict(), "summary": summary,
        "onnx_max_abs_diff_vs_float64": float(np.max(np.abs(onnx_out - ref))),
        "timing": {"features_s": round(t_features, 3), "train_s": round(t_train, 3),
                   "cross_validation_s": round(t_cv, 3),
                   "total_s": round(time.perf_counter() - t_all, 3),
                   "latency_model_ms": lat_model,
                   "latency_1s_audio_44k1_ms": lat_total},
    }
    files = [model_path, out / REPORT_FILE]
    (out / REPORT_FILE).write_text(json.dumps(json_safe(report), indent=1) + "\n",
                                   encoding="utf-8")
    if plot:
        files.append(plot_confusion(
            ev, out / CONFUSION_FILE,
            f"{kind}: {100 * ev.accuracy:.2f} % of {ev.n} test windows "
            f"({evaluation.recordings.n} held-out recordings"
            + (f", {folds}-fold cross-validation)" if folds > 1 else ")")))
    return TrainResult(out, model_path, evaluation, report, files, mlp)
