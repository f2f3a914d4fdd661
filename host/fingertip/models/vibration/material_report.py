"""The material trainer's outputs: the ONNX model, ``report.json`` and its figures.

For every candidate the report gives its accuracy by decision time, its training seconds
(its cross-validation, and one fold's fit) and its latency per answer (onnxruntime), and
``candidates.png`` plots accuracy against training time, so a user sees what each point of
accuracy costs.
"""
from __future__ import annotations

import json
import math
import os
import tempfile
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .classify import (
    Dataset,
    dataset_summary,
    json_safe,
    latency_ms,
    model_metadata,
    plot_confusion,
    split_report,
)
from ...outputs import write_text
from .features import as_recording
from .material_run import Final, TrainingRun, TrainResult, evaluation_of
from .reliability import apply_temperature, ece, plot_reliability
from .scores import UNKNOWN_KEEP, accuracy_by_time, decision_curve, ece_of, time_to_decision
from ..nets.figures import pyplot, save_png

if TYPE_CHECKING:
    from .candidates import Candidate

MODEL_FILE = "material.onnx"
REPORT_FILE = "report.json"
CONFUSION_FILE = "confusion.png"
DECISION_FILE = "decision.png"
RELIABILITY_FILE = "reliability.png"
CANDIDATES_FILE = "candidates.png"


def write_outputs(run: TrainingRun, cand: Candidate, final: Final, why: str, aug_report: dict,
                  out: str | os.PathLike, kind: str, folds: int, test_fraction: float,
                  plot: bool, t_all: float):
    """Export the chosen model, measure every candidate's cost, write the report and the
    figures; returns the :class:`~.material.TrainResult`."""
    from .classify import VibrationClassifier

    ds, labels, chosen = run.ds, run.labels, cand.name
    evaluated = final.evaluated
    evaluation = evaluation_of(evaluated, labels, ds.classes)
    table = accuracy_by_time(evaluated, labels)
    curve = decision_curve(evaluated, labels)
    ttd = time_to_decision(curve)
    ece_val, conf, ok = ece_of(evaluated, labels)
    _, conf_raw, ok_raw = ece_of(final.answers if folds > 1 else
                                 {i: _warm(a, final.temperature)
                                  for i, a in evaluated.items()}, labels)
    novelty = final.novelty
    unknown_share = float(np.mean([a.dist[-1] > novelty.threshold
                                   for a in evaluated.values()])) if evaluated else 0.0
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    summary = {"model": chosen, "accuracy": evaluation.windows.accuracy,
               "recording_accuracy": evaluation.recordings.accuracy,
               "accuracy_by_time": {k: v["accuracy"] for k, v in table.items()},
               "time_to_decision": ttd, "ece": ece_val,
               "test_windows": evaluation.windows.n,
               "test_recordings": evaluation.recordings.n, "folds": folds,
               "temperature": final.temperature, "novelty_threshold": novelty.threshold,
               "test_answered_unknown": unknown_share}
    meta = model_metadata(kind, cand.pipe.cfg, cand.pipe.spec, ds.classes, model=chosen,
                          evaluation=summary, trained_rates_hz=ds.rates,
                          temperature=final.temperature, novelty=novelty.to_dict())
    name = f"{kind}.onnx" if kind != "material" else MODEL_FILE
    model_path = final.fitted.export(out / name, final.temperature, meta)
    done = run.bars("costs (latency per candidate)", len(run.cands))
    costs = candidate_costs(run, model_path, chosen, done)
    for k, v in costs.items():
        run.results[k]["cost"] = v
    cw = run.bank.view(cand)
    clf = VibrationClassifier(model_path)
    probe_x = cw.test[int(run.train_idx[0])].inputs[:64]
    onnx_diff = float(np.max(np.abs(clf.predict(probe_x) - apply_temperature(
        final.fitted.forward(probe_x), final.temperature))))
    report = {
        "kind": kind, "model": chosen, "model_file": model_path.name,
        "dataset": dataset_summary(ds),
        "short_recordings": [ds.rel(it) for it, w in zip(ds.items, cw.test, strict=True)
                             if not len(w)],
        "setup": run.setup.to_dict(), "features": cand.pipe.cfg.to_dict(),
        "window": {"input": "growing", "first_s": run.setup.first_s,
                   "longest_s": run.setup.longest_s, "step_s": run.setup.step_s,
                   "frames": cand.pipe.spec.frames, "min_frames": cand.pipe.spec.min_frames,
                   "stats": list(cand.pipe.spec.stats)},
        "candidates": run.results, "candidates_skipped": run.skipped, "choice": why,
        "augmentation": aug_report,
        "mains_notch": run.results[chosen].pop("mains_notch_trial"),
        "split": _split(ds, folds, run.folds, run.train_idx, run.test_idx), "seed": run.seed,
        "test_fraction": test_fraction if folds <= 1 else None,
        "evaluation": evaluation.to_dict(), "summary": summary,
        "accuracy_by_time": table, "decision_curve": curve,
        "calibration": {"method": "temperature scaling on out-of-fold answers of the "
                                  "training folds", "fold_temperatures": final.temps,
                        "temperature": final.temperature, "ece": ece_val,
                        "ece_uncalibrated": ece(conf_raw, ok_raw)},
        "unknown": {"novelty_threshold": novelty.threshold,
                    "test_answered_unknown": unknown_share,
                    "rule": "answer unknown when the input's distance to the nearest trained "
                            "class (Mahalanobis, each class's own covariance) exceeds "
                            f"what {100 * UNKNOWN_KEEP:g} % of the known recordings reached "
                            "(out of fold, whole recording)"},
        "onnx_max_abs_diff_vs_float64": onnx_diff,
        "timing": {"features_s": round(run.timing["features_s"], 3),
                   "augment_s": round(run.timing["augment_s"], 3),
                   "mains_notch_s": round(run.timing["mains_notch_s"], 3),
                   "cross_validation_s": round(run.timing["cross_validation_s"]
                                               + run.timing["augment_s"]
                                               + run.timing["mains_notch_s"], 3),
                   "train_s": round(final.seconds, 3), "jobs": run.jobs,
                   "total_s": round(time.perf_counter() - t_all, 3),
                   "latency_model_ms": costs[chosen]["latency_model_ms"],
                   "latency_1s_audio_44k1_ms": costs[chosen]["latency_1s_audio_44k1_ms"]},
    }
    files = [model_path, out / REPORT_FILE]
    write_text(out / REPORT_FILE, json.dumps(json_safe(report), indent=1) + "\n")
    if plot:
        ev = evaluation.recordings
        files.append(plot_confusion(
            ev, out / CONFUSION_FILE,
            f"{kind} ({chosen}): {100 * ev.accuracy:.2f} % of {ev.n} held-out recordings"
            + (f" ({folds}-fold cross-validation)" if folds > 1 else "")))
        files.append(plot_decision(table, curve, out / DECISION_FILE, chosen))
        files.append(plot_reliability(conf, ok, out / RELIABILITY_FILE,
                                      f"{chosen}: ECE {ece_val:.3f} (T = "
                                      f"{final.temperature:.2f}) over {len(conf)} answers "
                                      "at the decision times"))
        files.append(plot_candidates({ds.folder.name or "data": report}, out / CANDIDATES_FILE))
    return TrainResult(out, model_path, evaluation, report, files, final.fitted.model)


def _warm(a, t: float):
    from .scores import cooled

    return cooled(a, 1 / t)


def candidate_costs(run: TrainingRun, model_path: Path, chosen: str, done=None) -> dict:
    """Per candidate: parameters, training time of its last cross-validation fold,
    onnxruntime latency of one answer, and features + model for 1 s of 44.1 kHz audio."""
    from .classify import VibrationClassifier
    from .classify import model_metadata as meta_of
    from .cross_validation import fit_on

    ds = run.ds
    out = {}
    folds = run.folds or [run.test_idx]
    idx = np.setdiff1d(run.train_idx, folds[0]) if len(folds[0]) else run.train_idx
    rate = max(44100.0, max(ds.rates))
    probe = as_recording(np.random.default_rng(0).normal(0, 0.05, int(rate)), rate,
                         "latency probe", full_scale=1.0)
    with tempfile.TemporaryDirectory() as tmp:
        for cand in run.cands:
            m = cand.last
            t_fit = cand.last_fit_s
            if m is None:  # no cross-validation ran: fit once to measure
                t0 = time.perf_counter()
                m = fit_on(cand, run.bank.view(cand), run.labels, idx, ds.classes, run.seed)
                t_fit = time.perf_counter() - t0
            meta = meta_of("material", cand.pipe.cfg, cand.pipe.spec, ds.classes,
                           model=cand.name)
            path = model_path if cand.name == chosen else m.export(
                Path(tmp) / f"{cand.name}.onnx", 1.0, meta)
            clf = VibrationClassifier(path)
            one = clf.pipeline.windows(probe).inputs[-1:]
            out[cand.name] = {"parameters": m.n_params,
                              "train_s_one_fold": round(t_fit, 3),
                              "latency_model_ms": latency_ms(
                                  lambda c=clf, x=one: c.predict(x), repeats=100),
                              "latency_1s_audio_44k1_ms": latency_ms(
                                  lambda c=clf: c.classify(probe), repeats=10, warmup=2)}
            if done is not None:
                done()
    return out


def _split(ds: Dataset, folds: int, sel_folds, train_idx, test_idx) -> dict:
    if folds > 1:
        return {"by": "recording", "cross_validation_folds": folds,
                "per_class": {c: {"recordings": n} for c, n in ds.counts().items()},
                "folds": [[ds.rel(ds.items[i]) for i in te] for te in sel_folds],
                "exported_model": "trained on every recording after the cross-validation"}
    out = split_report(ds, train_idx, test_idx)
    out["model_choice"] = (f"{len(sel_folds)}-fold cross-validation of the training "
                           "recordings" if sel_folds else "no cross-validation (too few "
                           "training recordings per class)")
    return out


def plot_decision(table: dict[str, dict], curve: list[dict], path: str | os.PathLike,
                  name: str = "") -> Path:
    """Accuracy against time: at fixed decision times, and at each confidence threshold
    (median time to decision), the way a user chooses a threshold."""
    plt = pyplot()

    fig, ax = plt.subplots(figsize=(5.2, 3.8), dpi=110)
    pts = [(v["seconds"], v["accuracy"]) for v in table.values()
           if v["seconds"] is not None and v["recordings"] and math.isfinite(v["accuracy"])]
    if pts:
        ax.plot(*zip(*pts, strict=True), "o-", label="fixed decision time")
    ax.plot([r["median_s"] for r in curve], [r["accuracy"] for r in curve], "s--",
            color="C1", label="threshold (median time to decision)")
    for r in curve:
        ax.annotate(f"{r['threshold']:g}", (r["median_s"], r["accuracy"]), fontsize=6,
                    xytext=(3, -8), textcoords="offset points")
    whole = table.get("whole")
    if whole and whole["recordings"]:
        ax.axhline(whole["accuracy"], color="grey", lw=1, ls=":", label="whole recording")
    ax.set_xlabel("seconds from the start of the slide")
    ax.set_ylabel("accuracy (per recording)")
    ax.set_title(f"{name}: accuracy against decision time (cross-validation folds)",
                 fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower right")
    return save_png(fig, path)


def plot_candidates(reports: dict[str, dict], path: str | os.PathLike) -> Path:
    """Each candidate's mean accuracy over the decision times against its training time
    (its whole cross-validation, seconds, log scale), one colour per set of ``reports``
    (name -> training report), the chosen ones circled."""
    plt = pyplot()

    fig, ax = plt.subplots(figsize=(6.0, 4.0), dpi=110)
    for k, (label, rep) in enumerate(reports.items()):
        # a candidate stopped early: its accuracy on the folds it ran, an open marker
        pts = [(c["cross_validation_s"], c.get("mean_accuracy_folds_run", c["mean_accuracy"]),
                n, bool(c.get("stopped"))) for n, c in rep["candidates"].items()
               if c.get("cross_validation_s")]
        pts = [p for p in pts if p[1] is not None and math.isfinite(p[1])]
        if not pts:
            continue
        full = [p for p in pts if not p[3]]
        if full:
            ax.plot([p[0] for p in full], [p[1] for p in full], "o", color=f"C{k}",
                    label=label)
        part = [p for p in pts if p[3]]
        if part:
            ax.plot([p[0] for p in part], [p[1] for p in part], "o", mfc="none",
                    mec=f"C{k}", label=f"{label} (stopped early, folds run)")
        for x, y, n, _ in pts:
            ax.annotate(n, (x, y), fontsize=6, xytext=(3, 2), textcoords="offset points")
            if n == rep["model"]:
                ax.plot([x], [y], "o", ms=11, mfc="none", mec=f"C{k}")
    ax.set_xscale("log")
    ax.set_xlabel("training seconds (cross-validation of the candidate)")
    ax.set_ylabel("mean accuracy over the decision times")
    ax.set_title("candidates: accuracy against training time (chosen circled)", fontsize=9)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, loc="lower right")
    return save_png(fig, path)
