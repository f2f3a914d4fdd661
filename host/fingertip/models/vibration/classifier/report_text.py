"""Training reports of the vibration classifiers in words, as ``fingertip train`` prints
them: one function per part, each returning lines (the caller prints or logs them)."""
from __future__ import annotations

import math
from typing import Any


def evaluation_lines(ev: Any, indent: str = "  ", how: str = "majority vote"
                     ) -> list[str]:
    """A :class:`ModelEvaluation` in words: accuracy per window and per recording
    (``how`` the recording's answer is made), recall and precision per class, the pair most
    confused."""
    out: list[str] = []
    w = ev.windows
    out.append(f"{indent}accuracy: {100 * w.accuracy:.2f} % of {w.n} test windows; "
               f"{100 * ev.recordings.accuracy:.1f} % of {ev.recordings.n} test recordings "
               f"({how})")
    rec, prec = w.recall, w.precision
    width = max(len(c) for c in w.classes)
    out.append(f"{indent}{'class':<{width}}  recall  precision  windows")
    for i, c in enumerate(w.classes):
        out.append(f"{indent}{c:<{width}}  {100 * rec[c]:5.1f} %  {100 * prec[c]:6.1f} %  "
                   f"{int(w.confusion[i].sum()):7d}")
    a, b, k = w.most_confused()
    if k:
        out.append(f"{indent}most confused: {a} <-> {b} ({k} windows)")
    return out


def split_line(split: dict) -> str:
    """How the recordings were split between training and test (or cross-validated)."""
    per = split["per_class"]
    if split.get("cross_validation_folds"):
        n = sum(v["recordings"] for v in per.values())
        return (f"{split['cross_validation_folds']}-fold cross-validation by recording: each "
                f"of the {n} recordings tested once by a model that never saw it; the "
                f"exported model is trained on all of them")
    tr = sum(v["train"] for v in per.values())
    te = sum(v["test"] for v in per.values())
    va = sum(v.get("validation", 0) for v in per.values())
    extra = f", {va} for validation" if va else ""
    return (f"split by recording: {tr} train{extra}, {te} test recordings "
            f"(no recording on both sides; per class in report.json)")


def material_report_lines(rep: dict) -> list[str]:
    """A material training report in words: the windows and why, each candidate's
    accuracy per decision time and cost (parameters, latency per answer, seconds of its
    cross-validation), the choice, augmentation, decision threshold and
    calibration."""
    out: list[str] = []
    st = rep["setup"]
    out.append(f"windows: first answer after {st['first_window_s']:g} s, one every "
               f"{st['step_s']:g} s, growing to {st['longest_window_s']:g} s")
    for why in st["why"].values():
        out.append(f"  {why}")
    times = list(next(iter(rep["candidates"].values()))["accuracy_by_time"]) or ["whole"]
    out.append("candidates (accuracy per recording at each decision time; cost):")
    out.append("  " + f"{'model':<9}" + "".join(f"{t:>8}" for t in times)
               + "   params  ms/answer  train s")
    for name, c in rep["candidates"].items():
        acc = c["accuracy_by_time"]
        cells = "".join(f"{100 * acc[t]['accuracy']:7.1f}%" if t in acc and
                        acc[t]["recordings"] else f"{'-':>8}" for t in times)
        cost = c.get("cost", {})
        out.append(f"  {name:<9}{cells} {cost.get('parameters', 0):8,d} "
                   f"{cost.get('latency_model_ms', {}).get('p50', math.nan):9.3f} "
                   f"{c.get('cross_validation_s', math.nan):8.1f}"
                   + (f"  ({c['folds_run']} folds: stopped)" if c.get("stopped") else ""))
    for name, why in rep.get("candidates_skipped", {}).items():
        out.append(f"  {name:<9}skipped: {why}")
    for name, c in rep["candidates"].items():
        if c.get("stopped"):
            out.append(f"  {name} stopped: {c['stopped']}")
    out.append(f"chosen: {rep['choice']}")
    if "mains_notch" in rep:
        out.append(f"mains notch: {rep['mains_notch']['why']}")
    if "augmentation" in rep:
        out.append(f"augmentation: {rep['augmentation']['why']}")
    ttd = rep["summary"]["time_to_decision"]
    if ttd.get("threshold") is not None:
        out.append(f"decisions {100 * ttd['target_accuracy']:g} % right: threshold "
                   f"{ttd['threshold']:g}, median {ttd['median_s']:.3f} s to decide")
    cal = rep["calibration"]
    out.append(f"calibration: temperature {cal['temperature']:.2f}, ECE {cal['ece']:.3f} "
               f"(uncalibrated {cal['ece_uncalibrated']:.3f}); unknown beyond distance "
               f"{rep['unknown']['novelty_threshold']:.2f}")
    return out


def material_summary_lines(r: Any) -> list[str]:
    """What ``fingertip train material`` prints for ``r`` (a material training result):
    the dataset, the split, the report and the test evaluation."""
    d = r.report["dataset"]
    return ([f"dataset: {sum(d['recordings'].values())} recordings in {len(d['classes'])} "
             f"classes at {', '.join(f'{x:g}' for x in d['rates_hz'])} Hz; bands "
             f"{r.report['features']['f_lo']:g}-{r.report['features']['f_hi']:g} Hz",
             split_line(r.report["split"])]
            + material_report_lines(r.report)
            + evaluation_lines(r.evaluation, how="answer after the whole recording"))


def shake_summary_lines(r: Any) -> list[str]:
    """What ``fingertip train shake`` prints for ``r`` (a shake training result): the
    split, each model's cost and evaluation, and the verdict between them."""
    out = [split_line(r.report["split"])]
    for name, res in r.results.items():
        out.append(f"{name.upper()}: {res.cost['parameters']:,} parameters, trained in "
                        f"{res.cost['train_s']:.1f} s, {res.cost['latency_model_ms']['p50']:.3f} "
                        "ms per prediction (onnxruntime, p50)")
        out += evaluation_lines(res.evaluation)
    out.append(f"verdict: {r.verdict}")
    return out
