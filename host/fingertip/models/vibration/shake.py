"""What is in the box, from shaking it: ``fingertip train shake FOLDER``.

The paper shakes a box (screws, rubber bands, or an empty grasp) for 5.6 s, cuts the
spectrogram into 86-frame windows, encodes them with a ResNet and an MLP head, predicts at
10 Hz and takes a majority vote per shake (94.64 % of 26 trials). Here, from the same
86-frame windows (1.0 s) every 0.1 s:

- ``cnn``: the small ResNet of :mod:`.cnn` on the window's gain-free log band spectrogram
  (86 x 32), trained in numpy with early stopping on held-out recordings;
- ``mlp``: an MLP on the window's pooled features (mean, spread and frame-to-frame change
  of each band, 96 numbers; :func:`~fingertip.models.vibration.window_features.pooled`);

both exported to ONNX and evaluated on the same held-out recordings (split by recording,
stratified): accuracy per window (one 10 Hz prediction) and per shake (majority vote),
recall, confusion matrices; and their cost side by side: parameters, multiply-adds, training
time, latency per prediction with onnxruntime (the model alone, and from one window of
44.1 kHz audio, 1.02 s, to a prediction). ``report.md`` states whether the CNN is worth
it on this data.
"""
from __future__ import annotations

import json
import logging
import math
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
    VibrationClassifier,
    Windows,
    WindowSpec,
    dataset_summary,
    dataset_windows,
    evaluate_model,
    json_safe,
    latency_ms,
    load_folder,
    model_metadata,
    paired_difference,
    plot_confusion,
    require_test_set,
    split_by_recording,
    split_report,
    stack,
    validation_split,
)
from ...outputs import write_text
from ..nets.cnn import CnnSpec, SmallResNet, blas_threads, train_cnn
from .features import FeatureConfig, as_recording
from .window_features import pooled

log = logging.getLogger(__name__)

WINDOW_FRAMES = 86
STEP_S = 0.1
MODELS = ("cnn", "mlp")
MLP_HIDDEN = (32,)
REPORT_FILE = "report.json"
TABLE_FILE = "report.md"


@dataclass
class ModelResult:
    name: str
    path: Path
    evaluation: ModelEvaluation
    cost: dict


@dataclass
class ShakeResult:
    out: Path
    results: dict[str, ModelResult]
    report: dict
    verdict: str
    files: list[Path] = field(default_factory=list)


def shake_spec(input: str, step_s: float = STEP_S, frames: int = WINDOW_FRAMES) -> WindowSpec:
    return WindowSpec(frames, step_s, input)


def cnn_macs(model: SmallResNet) -> int:
    """Multiply-adds of one prediction (convolutions and dense layers)."""
    sp = model.spec
    h, w = (sp.frames - 1) // 2 + 1, (sp.bands - 1) // 2 + 1
    total = h * w * 9 * sp.channels[0]
    for a, b, s in sp.blocks():
        ho, wo = (h - 1) // s + 1, (w - 1) // s + 1
        total += ho * wo * 9 * a * b + ho * wo * 9 * b * b
        if a != b or s != 1:
            total += ho * wo * a * b
        h, w = ho, wo
    last = sp.channels[-1]
    if sp.head:
        total += last * sp.head
        last = sp.head
    return int(total + last * sp.n_classes)


def _pooled_windows(ws: list[Windows]) -> list[Windows]:
    return [Windows(pooled(w.inputs) if len(w) else np.zeros((0, 3 * w.inputs.shape[-1])),
                    w.t_start, w.t_end, w.level_db, w.clipped) for w in ws]


def train_shake(folder: str | os.PathLike | Dataset, out: str | os.PathLike, *,
                models: tuple[str, ...] = MODELS, step_s: float = STEP_S,
                train_step_s: float | None = None, test_fraction: float = 0.25, seed: int = 0,
                rate_hint: float | None = None, max_hz: float | None = None,
                cnn_spec: CnnSpec | None = None, cnn_epochs: int = 40,
                cnn_max_seconds: float | None = None, mlp_hidden: tuple[int, ...] = MLP_HIDDEN,
                features: FeatureConfig | None = None, plot: bool = True) -> ShakeResult:
    """Train and compare the CNN and the MLP on a class-per-sub-folder dataset of shakes.

    ``step_s``: prediction step (0.1 s = 10 Hz), also the step of the test windows;
    ``train_step_s``: step of the training windows (default: ``step_s`` for the MLP, and at
    least 0.2 s for the CNN, whose training cost grows with every window).
    """
    bad = set(models) - set(MODELS)
    if bad or not models:
        raise ValueError(f"models must be among {MODELS}, not {sorted(bad) or 'none'}")
    t_all = time.perf_counter()
    ds = folder if isinstance(folder, Dataset) else load_folder(folder, rate_hint=rate_hint)
    cfg = (features or FeatureConfig()).for_rates(ds.rates, max_hz)
    labels = ds.labels
    train_idx, test_idx = split_by_recording(labels, test_fraction, seed)
    require_test_set(test_idx)
    fit_idx, val_idx = validation_split(labels, train_idx, seed)

    spec_test = shake_spec("spectrogram", step_s)
    t0 = time.perf_counter()
    test_w, short = dataset_windows(ds, FeaturePipeline(cfg, spec_test))
    t_features = time.perf_counter() - t0
    if short:
        log.warning("%d recording(s) shorter than one 86-frame window (1.0 s) give no "
                    "window: %s", len(short), ", ".join(short[:5]))

    def train_windows(step: float) -> list[Windows]:
        if abs(step - step_s) < 1e-12:
            return test_w
        return dataset_windows(ds, FeaturePipeline(cfg, shake_spec("spectrogram", step)))[0]

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    results: dict[str, ModelResult] = {}
    files: list[Path] = []
    span = FeaturePipeline(cfg, spec_test).span_s()
    probe = as_recording(np.random.default_rng(0).normal(0, 0.05, int(span * 44100) + 2),
                         44100, "latency probe", full_scale=1.0)
    common = {"evaluation_step_s": step_s}

    if "mlp" in models:
        from ..nets.mlp import to_onnx, train_mlp

        step = train_step_s or step_s
        tw = _pooled_windows(train_windows(step))
        x, y, _ = stack(tw, labels, train_idx)
        _check_training(x, y, ds)
        t0 = time.perf_counter()
        with blas_threads(1):
            mlp = train_mlp(x, y, hidden=mlp_hidden, task="classification",
                            classes=ds.classes, seed=seed)
        t_train = time.perf_counter() - t0
        ev = evaluate_model(mlp.forward, _pooled_windows(test_w), labels, test_idx,
                            ds.classes)
        spec = shake_spec("pooled", step_s)
        meta = model_metadata("shake", cfg, spec, ds.classes, model="mlp",
                              evaluation=_summary(ev), trained_rates_hz=ds.rates, **common)
        path = to_onnx(mlp, out / "shake_mlp.onnx", metadata=meta)
        cost = _cost(path, probe, mlp.n_params, int(sum(w.size for w in mlp.weights)),
                     t_train, len(x), step)
        cost["hidden"] = list(mlp_hidden)
        results["mlp"] = ModelResult("mlp", path, ev, cost)

    if "cnn" in models:
        step = train_step_s or max(step_s, 0.2)
        tw = train_windows(step)
        x, y, _ = stack(tw, labels, fit_idx)
        _check_training(x, y, ds)
        xv, yv, _ = stack(tw, labels, val_idx)
        t0 = time.perf_counter()
        cnn, info = train_cnn(x, y, classes=ds.classes, x_val=xv if len(xv) else None,
                              y_val=yv if len(yv) else None, spec=cnn_spec,
                              epochs=cnn_epochs, max_seconds=cnn_max_seconds, seed=seed)
        t_train = time.perf_counter() - t0
        ev = evaluate_model(lambda a: cnn.forward(a, np.float32), test_w, labels, test_idx,
                            ds.classes)
        spec = shake_spec("spectrogram", step_s)
        meta = model_metadata("shake", cfg, spec, ds.classes, model="cnn",
                              evaluation=_summary(ev), trained_rates_hz=ds.rates, **common)
        path = cnn.to_onnx(out / "shake_cnn.onnx", metadata=meta)
        cost = _cost(path, probe, cnn.n_params, cnn_macs(cnn), t_train, len(x), step)
        cost.update({"epochs": info.epochs, "best_epoch": info.best_epoch,
                     "validation_windows": int(len(xv)),
                     "architecture": {"channels": list(cnn.spec.channels),
                                      "head": cnn.spec.head}})
        results["cnn"] = ModelResult("cnn", path, ev, cost)

    for name, r in results.items():
        if plot:
            e = r.evaluation
            files.append(plot_confusion(
                e.windows, out / f"confusion_{name}.png",
                f"shake, {name.upper()}: {100 * e.windows.accuracy:.2f} % of "
                f"{e.windows.n} windows, {100 * e.recordings.accuracy:.1f} % of "
                f"{e.recordings.n} shakes (vote)"))
    verdict = compare(results)
    report = {
        "kind": "shake", "dataset": dataset_summary(ds), "short_recordings": short,
        "features": cfg.to_dict(),
        "window": {"frames": WINDOW_FRAMES, "seconds": round(WINDOW_FRAMES * cfg.hop_s, 3),
                   "span_s": round(span, 4), "step_s": step_s},
        "split": split_report(ds, train_idx, test_idx, val_idx), "seed": seed,
        "test_fraction": test_fraction,
        "models": {n: {"file": r.path.name, "evaluation": r.evaluation.to_dict(),
                       "summary": _summary(r.evaluation), "cost": r.cost}
                   for n, r in results.items()},
        "verdict": verdict,
        "timing": {"features_s": round(t_features, 3),
                   "total_s": round(time.perf_counter() - t_all, 3)},
    }
    write_text(out / REPORT_FILE, json.dumps(json_safe(report), indent=1) + "\n")
    write_text(out / TABLE_FILE, comparison_table(results, verdict))
    files = [r.path for r in results.values()] + [out / REPORT_FILE, out / TABLE_FILE] + files
    return ShakeResult(out, results, report, verdict, files)


def _check_training(x: np.ndarray, y: np.ndarray, ds: Dataset) -> None:
    if not len(x):
        raise DatasetError("no training windows: shake recordings must last 1.0 s or more")
    if len(np.unique(y)) < len(ds.classes):
        raise DatasetError("some class has no training window (recordings too short?)")


def _summary(ev: ModelEvaluation) -> dict:
    return {"window_accuracy": ev.windows.accuracy, "vote_accuracy": ev.recordings.accuracy,
            "test_windows": ev.windows.n, "test_recordings": ev.recordings.n}


def _cost(path: Path, probe, n_params: int, macs: int, t_train: float, n_train: int,
          train_step_s: float) -> dict:
    clf = VibrationClassifier(path)
    one = clf.pipeline.windows(probe).inputs[:1]
    return {"parameters": int(n_params), "multiply_adds": int(macs),
            "train_s": round(t_train, 3), "train_windows": int(n_train),
            "train_step_s": train_step_s,
            "latency_model_ms": latency_ms(lambda: clf.predict(one)),
            "latency_window_audio_ms": latency_ms(lambda: clf.classify(probe), repeats=50),
            "file_bytes": path.stat().st_size}


def compare(results: dict[str, ModelResult]) -> str:
    """A measured answer to "is the CNN worth its cost?" on this evaluation.

    The accuracy difference is paired by test recording (each recording's share of correct
    windows, CNN minus MLP): it counts only when it exceeds twice its standard error.
    """
    if not {"cnn", "mlp"} <= set(results):
        return "only one model trained: no comparison"
    c, m = results["cnn"], results["mlp"]
    d, se, n = paired_difference(c.evaluation, m.evaluation)
    dv = c.evaluation.recordings.accuracy - m.evaluation.recordings.accuracy
    lat = c.cost["latency_model_ms"]["p50"] / max(1e-9, m.cost["latency_model_ms"]["p50"])
    lat_e2e = c.cost["latency_window_audio_ms"]["p50"] / max(
        1e-9, m.cost["latency_window_audio_ms"]["p50"])
    tr = c.cost["train_s"] / max(1e-9, m.cost["train_s"])
    cost = (f"the CNN costs {lat:.0f}x the MLP's model latency ({lat_e2e:.1f}x end to end "
            f"from raw audio), {c.cost['parameters'] / max(1, m.cost['parameters']):.1f}x "
            f"its parameters and {tr:.0f}x its training time")
    diff = (f"window accuracy {100 * d:+.2f} +- {100 * se:.2f} points (CNN - MLP, paired "
            f"over {n} test recordings), shake votes {100 * dv:+.1f} points")
    if not math.isfinite(d):
        return f"no common test recording: no comparison; {cost}"
    if d > 2 * se and d > 0.005 and dv >= 0:
        return f"CNN worth it if its cost is affordable: {diff}; {cost}"
    if d < -2 * se and d < -0.005:
        return f"CNN not worth it: the MLP is more accurate ({diff}), and {cost}"
    return f"CNN not worth it here: no significant accuracy gain ({diff}), while {cost}"


def comparison_table(results: dict[str, ModelResult], verdict: str) -> str:
    lines = ["# Shake classifiers: CNN against MLP", "",
             "| | " + " | ".join(n.upper() for n in results) + " |",
             "|---|" + "---|" * len(results)]

    def row(name: str, fn) -> None:
        lines.append(f"| {name} | " + " | ".join(fn(r) for r in results.values()) + " |")

    row("accuracy per window (10 Hz)", lambda r: f"{100 * r.evaluation.windows.accuracy:.2f} %")
    row("accuracy per shake (majority vote)",
        lambda r: f"{100 * r.evaluation.recordings.accuracy:.1f} % "
                  f"({np.trace(r.evaluation.recordings.confusion)}/{r.evaluation.recordings.n})")
    row("lowest recall (windows)",
        lambda r: "{}: {:.1f} %".format(*min(r.evaluation.windows.recall.items(),
                                             key=lambda kv: kv[1])[:1],
                                         100 * min(r.evaluation.windows.recall.values())))
    row("parameters", lambda r: f"{r.cost['parameters']:,}")
    row("multiply-adds per prediction", lambda r: f"{r.cost['multiply_adds']:,}")
    row("latency, model (p50)", lambda r: f"{r.cost['latency_model_ms']['p50']:.3f} ms")
    row("latency, 1.02 s of 44.1 kHz audio -> prediction (p50)",
        lambda r: f"{r.cost['latency_window_audio_ms']['p50']:.2f} ms")
    row("training time", lambda r: f"{r.cost['train_s']:.1f} s "
                                    f"({r.cost['train_windows']} windows)")
    lines += ["", f"Verdict: {verdict}.", ""]
    return "\n".join(lines)
