"""Material classification from sliding vibrations: ``fingertip train material FOLDER``.

The paper slides the fingernail 16 mm over seven materials, turns the contact microphone's
signal into STFT spectrograms and trains an MLP (95.49 %, copper tape and wax paper confused
most). A hand must decide during a slide, on sensors and materials we never saw, so here:

- the features and windows adapt to the recordings' rates and lengths
  (:func:`~fingertip.models.vibration.candidates.choose_setup`; the report says what and why);
- every model answers on *growing* windows (:mod:`.anytime`): at each step (10 Hz) the
  gain-free summary of the log band spectrum of everything heard so far (up to 2 s, then
  sliding), so one model answers at 0.25 s and at the end of a slide;
- candidates (the plain log-spectrum + logistic regression baseline, logistic regression on
  log bands, an MLP) are compared by cross-validation by recording, on their accuracy at
  decision times 0.25, 0.5, 1, 2 s and the whole recording, and the best (the cheapest when
  they tie) is exported to ONNX;
- its probabilities are temperature-scaled on out-of-fold answers, and a recording farther
  from every trained class than 95 % of the known recordings (Mahalanobis distance,
  :class:`~fingertip.models.vibration.reliability.Novelty`) is answered "unknown";
- the report (``report.json``) gives each candidate's accuracy by decision time and its
  cost, the accuracy against time to decision (``decision.png``), the expected calibration
  error (``reliability.png``) and the confusion matrix (``confusion.png``).
"""
from __future__ import annotations

import json
import logging
import math
import os
import tempfile
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from .anytime import DECISION_TIMES
from .augment import AugmentConfig
from .candidates import (
    CANDIDATES,
    CNN_EPOCHS,
    CNN_WORK_LIMIT,
    TIE,
    Answers,
    Candidate,
    Fitted,
    accuracy_by_time,
    answers_of,
    band_powers,
    calibrated,
    candidate_windows,
    candidates,
    cnn_work,
    choose_setup,
    cross_validate,
    cross_validate_against,
    decision_curve,
    ece_of,
    fit_on,
    fold_temperatures,
    UNKNOWN_KEEP,
    mean_accuracy,
    novelty_on,
    novelty_threshold,
    time_to_decision,
)
from .classify import (
    Dataset,
    ModelEvaluation,
    dataset_summary,
    evaluate,
    json_safe,
    latency_ms,
    load_folder,
    model_metadata,
    plot_confusion,
    require_test_set,
    split_by_recording,
    split_report,
    stratified_folds,
)
from .features import FeatureConfig, as_recording
from ..nets.figures import pyplot, save_png
from .mains_trial import try_mains_notch
from .reliability import apply_temperature, fit_temperature, plot_reliability

log = logging.getLogger(__name__)

HIDDEN = (64,)
MODEL_FILE = "material.onnx"
REPORT_FILE = "report.json"
CONFUSION_FILE = "confusion.png"
DECISION_FILE = "decision.png"
RELIABILITY_FILE = "reliability.png"


@dataclass
class TrainResult:
    out: Path
    model_path: Path
    evaluation: ModelEvaluation
    report: dict
    files: list[Path] = field(default_factory=list)
    model: object = None
    """The trained model (float64 reference of the exported ONNX graph, before the
    temperature)."""


def train_material(folder: str | os.PathLike | Dataset, out: str | os.PathLike, *,
                   window_s: float | None = None, step_s: float | None = None,
                   hidden: tuple[int, ...] = HIDDEN, test_fraction: float = 0.25,
                   seed: int = 0, rate_hint: float | None = None, max_hz: float | None = None,
                   epochs: int = 300, folds: int = 1, features: FeatureConfig | None = None,
                   kind: str = "material", plot: bool = True,
                   models: tuple[str, ...] = CANDIDATES,
                   augment: AugmentConfig | None = None,
                   cnn_budget: float | None = None,
                   mains_notch: bool | None = None) -> TrainResult:
    """Train and evaluate a material classifier on a class-per-sub-folder dataset.

    ``out``: output folder (created). ``rate_hint``: the rate of CSV files that do not state
    theirs. ``max_hz``: cap the bands. ``window_s`` / ``step_s``: the longest window and the
    step between answers (None: chosen from the data). ``folds`` > 1: k-fold
    cross-validation by recording chooses the model, calibrates it and is the evaluation;
    the exported model is then trained on every recording. ``folds`` 1: one split
    (``test_fraction`` held out); the choice and the calibration use a cross-validation of
    the training recordings only. ``models``: the candidates (see
    :data:`~fingertip.models.vibration.candidates.CANDIDATES`). ``augment``: augmented copies of
    each training recording (:mod:`.augment`; None: the defaults, one copy; only the
    training windows of each fold are augmented, never the answers scored).
    ``cnn_budget``: the CNN candidate is cross-validated only when its projected work
    (:func:`~fingertip.models.vibration.candidates.cnn_work`, window-epochs) is at most this
    (inf: no limit; None: :data:`~fingertip.models.vibration.candidates.CNN_WORK_LIMIT`); a
    count from the data, so the same folder always gives the same candidates.
    ``mains_notch``: notch steady mains lines out of every recording (:mod:`.mains`) or
    not; None (the default): tried by cross-validation when some training recording
    carries such lines, and kept when it costs no accuracy (:mod:`.mains_trial`).
    ``features`` with ``mains_notch`` set turns it on as well.
    """
    augment = AugmentConfig() if augment is None else augment
    cnn_budget = CNN_WORK_LIMIT if cnn_budget is None else cnn_budget
    if not cnn_budget > 0:
        raise ValueError(f"cnn_budget must be > 0 window-epochs (inf: no limit), not "
                         f"{cnn_budget}")
    t_all = time.perf_counter()
    if mains_notch is None and features is not None and features.mains_notch:
        mains_notch = True
    if mains_notch is not None:
        features = replace(features or FeatureConfig(), mains_notch=mains_notch)
    ds = folder if isinstance(folder, Dataset) else load_folder(folder, rate_hint=rate_hint)
    setup = choose_setup(ds, features, max_hz, window_s, step_s)
    labels = ds.labels
    n_rec = len(labels)
    if folds > 1:
        sel_folds = stratified_folds(labels, folds, seed)
        train_idx, test_idx = np.arange(n_rec), np.zeros(0, np.intp)
    else:
        train_idx, test_idx = split_by_recording(labels, test_fraction, seed)
        require_test_set(test_idx)
        least = int(np.bincount(labels[train_idx]).min())
        inner = min(3, least)
        sel_folds = [train_idx[f] for f in stratified_folds(labels[train_idx], inner, seed)] \
            if inner >= 2 else []
    n_fits = len(sel_folds) + 1
    # no time cap on the CNN's fits: a cap would make its result depend on the machine's
    # load; the work rule below bounds it instead
    cands = candidates(setup, models, hidden, epochs)
    results: dict[str, dict] = {}
    skipped: dict[str, str] = {}
    oof: dict[str, dict[int, Answers]] = {}
    cws = {}
    t_cv = time.perf_counter()
    powers: list[np.ndarray] | None = None
    for cand in list(cands):
        t0 = time.perf_counter()
        # the candidates on the adapted bands share one short-time spectrum per recording
        # (the first of them pays for it in its features_s)
        same = cand.pipe.cfg == setup.cfg
        if same and powers is None:
            powers = band_powers(cand.pipe, ds)
        cw = cws[cand.name] = candidate_windows(cand, ds, powers=powers if same else None)
        if cand.name == "cnn" and len(cands) > 1:
            need = cnn_work(cw, n_fits)
            if need > cnn_budget:
                skipped["cnn"] = (f"projected work {need} window-epochs "
                                  f"({sum(len(w) for w in cw.train)} training windows x "
                                  f"{CNN_EPOCHS} epochs x {n_fits} fits) exceeds its "
                                  f"budget of {cnn_budget:g}")
                log.info("candidate cnn skipped: %s", skipped["cnn"])
                cands.remove(cand)
                del cws[cand.name]
                continue
        ans = cross_validate(cand, cw, labels, sel_folds, ds.classes, seed) \
            if sel_folds else {}
        oof[cand.name] = ans
        table = accuracy_by_time(ans, labels) if ans else {}
        results[cand.name] = {"about": cand.about, "accuracy_by_time": table,
                              "mean_accuracy": mean_accuracy(table) if ans else math.nan,
                              "features_s": round(cw.seconds, 3),
                              "cross_validation_s": round(time.perf_counter() - t0, 3),
                              "inputs": int(cw.test[0].inputs.shape[1])
                              if len(cw.test[0]) else None}
    t_cv = time.perf_counter() - t_cv
    chosen, why = _choose(results, cands)
    cand = next(c for c in cands if c.name == chosen)
    t0 = time.perf_counter()
    if mains_notch is None:
        notch_report, won = try_mains_notch(cand, setup, ds, labels, sel_folds, oof[chosen],
                                            cws[chosen], seed, hidden, epochs)
        if won is not None:
            notched, setup, cws[chosen], oof[chosen] = won
            cands[cands.index(cand)] = cand = notched
            results[chosen]["mains_notch"] = True
            if oof[chosen]:  # no cross-validation (too few recordings): nothing to score
                table = accuracy_by_time(oof[chosen], labels)
                results[chosen].update(accuracy_by_time=table,
                                       mean_accuracy=mean_accuracy(table))
    else:
        notch_report = {"adopted": mains_notch,
                        "why": f"{'on' if mains_notch else 'off'}: asked (not tried)"}
    t_notch = time.perf_counter() - t0
    t_cv += t_notch
    t0 = time.perf_counter()
    aug_report = _try_augmentation(cand, ds, augment, seed, labels, sel_folds, results, cws,
                                   oof)
    t_augment = time.perf_counter() - t0
    t_cv += t_augment
    ans = oof[chosen]
    n_sel = len(sel_folds)
    temps = fold_temperatures(ans, labels, n_sel) if ans else []
    t_final = fit_temperature(*_pooled(ans, labels)) if ans else 1.0
    cal = calibrated(ans, temps) if ans else {}
    t0 = time.perf_counter()
    fitted = fit_on(cand, cws[chosen], labels, train_idx, ds.classes, seed)
    novelty = novelty_on(cws[chosen], labels, train_idx, len(ds.classes))
    novelty.threshold = novelty_threshold(ans)
    t_train = time.perf_counter() - t0
    if folds > 1:
        evaluated = cal
    else:
        evaluated = {int(i): _cooled(answers_of(fitted, cws[chosen].test[i], -1, novelty),
                                     t_final)
                     for i in test_idx if len(cws[chosen].test[i])}
    evaluation = _evaluation(evaluated, cws[chosen], labels, ds.classes)
    table = accuracy_by_time(evaluated, labels)
    curve = decision_curve(evaluated, labels)
    ttd = time_to_decision(curve)
    ece_val, conf, ok = ece_of(evaluated, labels)
    _, conf_raw, ok_raw = ece_of(ans if folds > 1 else
                                 {i: _cooled(a, 1 / t_final) for i, a in evaluated.items()},
                                 labels)
    from .reliability import ece as ece_fn

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
               "temperature": t_final, "novelty_threshold": novelty.threshold,
               "test_answered_unknown": unknown_share}
    meta = model_metadata(kind, cand.pipe.cfg,
                          cand.pipe.spec, ds.classes, model=chosen, evaluation=summary,
                          trained_rates_hz=ds.rates, temperature=t_final,
                          novelty=novelty.to_dict())
    name = f"{kind}.onnx" if kind != "material" else MODEL_FILE
    model_path = fitted.export(out / name, t_final, meta)
    costs = _costs(cands, cws, labels, sel_folds or [test_idx], train_idx, ds, seed,
                   model_path, chosen)
    for k, v in costs.items():
        results[k]["cost"] = v
    from .classify import VibrationClassifier

    clf = VibrationClassifier(model_path)
    probe_x = cws[chosen].test[int(train_idx[0])].inputs[:64]
    onnx_diff = float(np.max(np.abs(clf.predict(probe_x)
                                    - apply_temperature(fitted.forward(probe_x), t_final))))
    split = _split(ds, folds, sel_folds, train_idx, test_idx)
    report = {
        "kind": kind, "model": chosen, "model_file": model_path.name,
        "dataset": dataset_summary(ds),
        "short_recordings": [ds.rel(it) for it, w in zip(ds.items, cws[chosen].test,
                                                         strict=True) if not len(w)],
        "setup": setup.to_dict(), "features": cand.pipe.cfg.to_dict(),
        "window": {"input": "growing", "first_s": setup.first_s,
                   "longest_s": setup.longest_s, "step_s": setup.step_s,
                   "frames": cand.pipe.spec.frames, "min_frames": cand.pipe.spec.min_frames,
                   "stats": list(cand.pipe.spec.stats)},
        "candidates": results, "candidates_skipped": skipped, "choice": why,
        "augmentation": aug_report, "mains_notch": notch_report,
        "split": split, "seed": seed, "test_fraction": test_fraction if folds <= 1 else None,
        "evaluation": evaluation.to_dict(), "summary": summary,
        "accuracy_by_time": table, "decision_curve": curve,
        "calibration": {"method": "temperature scaling on out-of-fold answers of the "
                                  "training folds", "fold_temperatures": temps,
                        "temperature": t_final, "ece": ece_val,
                        "ece_uncalibrated": ece_fn(conf_raw, ok_raw)},
        "unknown": {"novelty_threshold": novelty.threshold,
                    "test_answered_unknown": unknown_share,
                    "rule": "answer unknown when the input's distance to the nearest trained "
                            "class (Mahalanobis, each class's own covariance) exceeds "
                            f"what {100 * UNKNOWN_KEEP:g} % of the known recordings reached "
                            "(out of fold, whole recording)"},
        "onnx_max_abs_diff_vs_float64": onnx_diff,
        "timing": {"features_s": round(sum(r["features_s"] for r in results.values()), 3),
                   "augment_s": round(t_augment, 3), "mains_notch_s": round(t_notch, 3),
                   "cross_validation_s": round(t_cv, 3), "train_s": round(t_train, 3),
                   "total_s": round(time.perf_counter() - t_all, 3),
                   "latency_model_ms": results[chosen]["cost"]["latency_model_ms"],
                   "latency_1s_audio_44k1_ms": results[chosen]["cost"]
                   ["latency_1s_audio_44k1_ms"]},
    }
    files = [model_path, out / REPORT_FILE]
    (out / REPORT_FILE).write_text(json.dumps(json_safe(report), indent=1) + "\n",
                                   encoding="utf-8")
    if plot:
        ev = evaluation.recordings
        files.append(plot_confusion(
            ev, out / CONFUSION_FILE,
            f"{kind} ({chosen}): {100 * ev.accuracy:.2f} % of {ev.n} held-out recordings"
            + (f" ({folds}-fold cross-validation)" if folds > 1 else "")))
        files.append(plot_decision(table, curve, out / DECISION_FILE, chosen))
        files.append(plot_reliability(conf, ok, out / RELIABILITY_FILE,
                                      f"{chosen}: ECE {ece_val:.3f} (T = {t_final:.2f}) over "
                                      f"{len(conf)} answers at the decision times"))
    return TrainResult(out, model_path, evaluation, report, files, fitted.model)


def _pooled(ans: dict[int, Answers], labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    from .candidates import _at_times

    return _at_times(ans, labels, DECISION_TIMES)


def _cooled(a: Answers, t: float) -> Answers:
    return Answers(apply_temperature(a.probs, t), apply_temperature(a.run, t), a.t_end, a.fold,
                   a.dist)


def _try_augmentation(cand: Candidate, ds: Dataset, augment: AugmentConfig, seed: int,
                      labels: np.ndarray, folds: list[np.ndarray], results: dict[str, dict],
                      cws: dict, oof: dict) -> dict:
    """Cross-validate the chosen candidate again with augmented training recordings
    (:mod:`.augment`) and keep the augmentation unless it costs more than :data:`TIE` of
    mean accuracy on the (never augmented) held-out recordings: robustness to other days
    is taken when it is free on the user's own data, and the report says what it costs when
    it is not. When the full draw (speed, hum, motor) is not adopted, its speed part alone
    (:meth:`~fingertip.models.vibration.augment.AugmentConfig.speed_only`) is tried by the same
    rule: on the simulated slides the added noises cost a linear model 2-3 points while a change
    of speed alone cost 0.3 and still lifted slow slides from 29 % to 54 %
    (docs/classifiers.md). Updates ``cws`` and ``oof`` in place when adopted."""
    out = {"settings": augment.to_dict(), "adopted": False,
           "rule": f"adopted unless the cross-validated mean accuracy drops by more than "
                   f"{100 * TIE:g} points; when the full draw is not adopted, its speed "
                   f"part alone is tried by the same rule"}
    base = results[cand.name]["mean_accuracy"]
    if not augment.copies or not folds or not math.isfinite(base):
        out["why"] = "no augmentation asked" if not augment.copies else \
            "too few recordings to cross-validate it"
        return out
    tried = []
    for cfg, what in ((augment, "augmentation"), (augment.speed_only(), "speed augmentation")):
        if tried and (cfg == augment or not augment.p_speed):
            break  # nothing but speed (already tried), or speed turned off by the caller
        one = _augmentation_trial(cand, ds, cfg, seed, labels, folds, base, cws, oof, what)
        tried.append(one)
        if one["adopted"]:
            break
    last = tried[-1]
    out.update({k: v for k, v in last.items() if k != "what"})
    out["why"] = "; ".join(t["why"] for t in tried)
    if len(tried) > 1:
        out["tried"] = tried
    return out


def _augmentation_trial(cand: Candidate, ds: Dataset, augment: AugmentConfig, seed: int,
                        labels: np.ndarray, folds: list[np.ndarray], base: float, cws: dict,
                        oof: dict, what: str) -> dict:
    """One augmentation setting cross-validated against the plain model's ``base`` mean
    accuracy (see :func:`_try_augmentation`)."""
    out: dict = {"settings": augment.to_dict(), "what": what}
    cw = candidate_windows(cand, ds, augment, seed, clean=cws[cand.name])
    trial = cross_validate_against(cand, cw, labels, folds, ds.classes, seed,
                                   oof[cand.name], base - TIE)
    ans, done = trial.answers, trial.folds_run
    if trial.table is None:
        bound = trial.bound
        out.update({"mean_accuracy_without": base, "mean_accuracy_with": None,
                    "mean_accuracy_with_at_most": bound, "folds_run": done,
                    "adopted": False})
        out["why"] = (f"{cand.name} with {what}: at most {100 * bound:.2f} % (after "
                      f"{done} of {len(folds)} folds, the others counted right) against "
                      f"{100 * base:.2f} % without: not adopted")
        log.info("%s", out["why"])
        return out
    table, acc = trial.table, trial.accuracy
    out.update({"mean_accuracy_without": base, "mean_accuracy_with": acc,
                "accuracy_by_time_with": table, "folds_run": done,
                "adopted": bool(acc >= base - TIE)})
    out["why"] = (f"{cand.name} with {what}: {100 * acc:.2f} % against "
                  f"{100 * base:.2f} % without: " + ("adopted" if out["adopted"] else
                                                     "not adopted"))
    log.info("%s", out["why"])
    if out["adopted"]:
        cws[cand.name], oof[cand.name] = cw, ans
    return out


def _choose(results: dict[str, dict], cands: list[Candidate]) -> tuple[str, str]:
    scored = {k: v["mean_accuracy"] for k, v in results.items()
              if math.isfinite(v["mean_accuracy"])}
    if not scored:
        name = "linear" if "linear" in results else next(iter(results))
        return name, f"{name}: too few training recordings per class to cross-validate"
    best = max(scored.values())
    order = [c.name for c in cands]  # cheapest first: baseline, linear, mlp
    tied = [n for n in order if n in scored and scored[n] >= best - TIE]
    name = tied[0]
    return name, (f"{name}: mean accuracy over the decision times {100 * scored[name]:.2f} "
                  f"% (best {100 * best:.2f} %; candidates within {100 * TIE:g} points of "
                  f"the best are tied and the cheapest of them wins)")


def _evaluation(ans: dict[int, Answers], cw, labels: np.ndarray, classes: list[str]
                ) -> ModelEvaluation:
    wt, wp, rt, rp = [], [], [], []
    per = {}
    for i, a in ans.items():
        hit = a.probs.argmax(axis=1)
        wt += [int(labels[i])] * len(hit)
        wp += hit.tolist()
        rt.append(int(labels[i]))
        rp.append(int(np.argmax(a.run[-1])))
        per[i] = float(np.mean(hit == labels[i]))
    return ModelEvaluation(evaluate(wt, wp, classes, "windows"),
                           evaluate(rt, rp, classes, "recordings"), per)


def _costs(cands, cws, labels, folds, train_idx, ds, seed, model_path, chosen) -> dict:
    """Per candidate: parameters, training time of its last cross-validation fold,
    onnxruntime latency of one answer, and features + model for 1 s of 44.1 kHz audio."""
    from .classify import VibrationClassifier

    out = {}
    idx = np.setdiff1d(train_idx, folds[0]) if len(folds) and len(folds[0]) else train_idx
    rate = max(44100.0, max(ds.rates))
    probe = as_recording(np.random.default_rng(0).normal(0, 0.05, int(rate)), rate,
                         "latency probe", full_scale=1.0)
    with tempfile.TemporaryDirectory() as tmp:
        for cand in cands:
            m: Fitted | None = cand.last
            t_fit = cand.last_fit_s
            if m is None:  # no cross-validation ran: fit once to measure
                t0 = time.perf_counter()
                m = fit_on(cand, cws[cand.name], labels, idx, ds.classes, seed)
                t_fit = time.perf_counter() - t0
            meta = model_metadata("material", cand.pipe.cfg, cand.pipe.spec, ds.classes,
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
