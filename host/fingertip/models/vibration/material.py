"""Material classification from sliding vibrations: ``fingertip train material FOLDER``.

The paper slides the fingernail 16 mm over seven materials, turns the contact microphone's
signal into STFT spectrograms and trains an MLP (95.49 %, copper tape and wax paper confused
most). A hand must decide during a slide, on sensors and materials we never saw, so here:

- the features and windows adapt to the recordings' rates and lengths
  (:func:`~.setup.choose_setup`; the report says what and why);
- every model answers on *growing* windows (:mod:`.anytime`): at each step (10 Hz) the
  gain-free summary of the log band spectrum of everything heard so far (up to 2 s, then
  sliding), so one model answers at 0.25 s and at the end of a slide;
- candidates (:mod:`.candidates`: logistic regressions, an MLP, their ensemble, an RBF
  SVM, boosted trees, a CNN) are compared by cross-validation by recording
  (:mod:`.cross_validation`), on their accuracy at decision times 0.25, 0.5, 1, 2 s and the
  whole recording, and the best (the cheapest when they tie) is exported to ONNX;
- its probabilities are temperature-scaled on out-of-fold answers, and a recording farther
  from every trained class than 95 % of the known recordings (Mahalanobis distance,
  :class:`~.reliability.Novelty`) is answered "unknown";
- the report (``report.json``, :mod:`.material_report`) gives each candidate's accuracy by
  decision time, its training seconds and its latency per answer, with figures.

Every fit is paid once: one spectrum per recording shared by every candidate and trial
(:mod:`.bank`), the ensemble's members reused from the other candidates' folds, folds on
every core (``jobs``), trials and costlier candidates stopped as soon as they cannot win
(:mod:`.choice`); a progress bar per phase on stderr (:mod:`.progress`).
"""
from __future__ import annotations

import logging
import math
import os
import time
from dataclasses import replace

import numpy as np
from threadpoolctl import threadpool_limits

from .augment import AugmentConfig
from .augment_trial import try_augmentation
from .bank import build_bank
from .candidates import DEFAULT_CANDIDATES, CNN_EPOCHS, CNN_WORK_LIMIT, Candidate, candidates
from .choice import choose, could_change, must_exceed
from .classify import (
    Dataset,
    load_folder,
    require_test_set,
    split_by_recording,
    stratified_folds,
)
from .cross_validation import (
    add_novelty,
    answers_of,
    cnn_work,
    cross_validate,
    cross_validate_against,
    fit_final,
    novelty_on,
    prepare_first_folds,
)
from .features import FeatureConfig
from .mains_trial import try_mains_notch
from .material_report import write_outputs
from .material_run import Final, TrainingRun, TrainResult
from .parallel import default_jobs
from .progress import Bars
from .reliability import fit_temperature
from .scores import (
    accuracy_by_time,
    at_times,
    calibrated,
    cooled,
    fold_temperatures,
    mean_accuracy,
    novelty_threshold,
)
from .setup import Setup, choose_setup

log = logging.getLogger(__name__)

HIDDEN = (64,)


def train_material(folder: str | os.PathLike | Dataset, out: str | os.PathLike, *,
                   window_s: float | None = None, step_s: float | None = None,
                   hidden: tuple[int, ...] = HIDDEN, test_fraction: float = 0.25,
                   seed: int = 0, rate_hint: float | None = None, max_hz: float | None = None,
                   epochs: int = 300, folds: int = 1, features: FeatureConfig | None = None,
                   kind: str = "material", plot: bool = True,
                   models: tuple[str, ...] = DEFAULT_CANDIDATES,
                   augment: AugmentConfig | None = None,
                   cnn_budget: float | None = None,
                   mains_notch: bool | None = None, jobs: int | None = None,
                   progress: bool = True, every_fold: bool = False) -> TrainResult:
    """Train and evaluate a material classifier on a class-per-sub-folder dataset.

    ``out``: output folder (created). ``rate_hint``: the rate of CSV files that do not state
    theirs. ``max_hz``: cap the bands. ``window_s`` / ``step_s``: the longest window and the
    step between answers (None: chosen from the data). ``folds`` > 1: k-fold
    cross-validation by recording chooses the model, calibrates it and is the evaluation;
    the exported model is then trained on every recording. ``folds`` 1: one split
    (``test_fraction`` held out); the choice and the calibration use a cross-validation of
    the training recordings only. ``models``: the candidates (default
    :data:`~.candidates.DEFAULT_CANDIDATES`; all: :data:`~.candidates.CANDIDATES`).
    ``augment``: augmented copies of each training recording (:mod:`.augment`; None: the
    defaults, one copy; only the training windows of each fold are augmented, never the
    answers scored). ``cnn_budget``: the CNN candidate
    is cross-validated only when its projected work (:func:`~.cross_validation.cnn_work`,
    window-epochs) is at most this (inf: no limit; None: :data:`~.candidates.CNN_WORK_LIMIT`);
    a count from the data, so the same folder always gives the same candidates.
    ``mains_notch``: notch steady mains lines out of every recording (:mod:`.mains`) or
    not; None (the default): tried by cross-validation when some training recording
    carries such lines, and kept when it costs no accuracy (:mod:`.mains_trial`).
    ``features`` with ``mains_notch`` set turns it on as well. ``jobs``: worker processes
    for the folds (None: every core, :func:`~.parallel.default_jobs`; the result does not
    depend on it). ``progress``: a bar per phase on stderr. ``every_fold``: cross-validate
    every candidate on every fold, also one that can no longer change the choice (by
    default it stops then, :mod:`.choice`: the same choice, but about once in a thousand
    stops by the confidence bound).
    """
    augment = AugmentConfig() if augment is None else augment
    cnn_budget = CNN_WORK_LIMIT if cnn_budget is None else cnn_budget
    if not cnn_budget > 0:
        raise ValueError(f"cnn_budget must be > 0 window-epochs (inf: no limit), not "
                         f"{cnn_budget}")
    jobs = default_jobs() if jobs is None else int(jobs)
    if jobs < 1:
        raise ValueError(f"jobs must be >= 1, not {jobs}")
    t_all = time.perf_counter()
    if mains_notch is None and features is not None and features.mains_notch:
        mains_notch = True
    if mains_notch is not None:
        features = replace(features or FeatureConfig(), mains_notch=mains_notch)
    ds = folder if isinstance(folder, Dataset) else load_folder(folder, rate_hint=rate_hint)
    # One BLAS thread in this process and the fold workers it forks (they inherit it):
    # the products here are small, and OpenBLAS's threads spin waiting for each other
    # when the cores are busy: a 170 x 129 by 129 x 145 product of the features took
    # 8 ms of CPU with two threads on a loaded 2-core machine, 0.07 ms with one.
    with threadpool_limits(1):
        run = _plan(ds, choose_setup(ds, features, max_hz, window_s, step_s), folds,
                    test_fraction, seed, jobs, Bars(progress))
        try:
            _cross_validate_candidates(run, candidates(run.setup, models, hidden, epochs),
                                       cnn_budget, every_fold)
            chosen, why = choose(run.results, run.cands)
            cand = _mains_step(run, chosen, mains_notch)
            aug_report = _augmentation_step(run, cand, augment)
            final = _final_step(run, cand)
            return write_outputs(run, cand, final, why, aug_report, out, kind, folds,
                                 test_fraction, plot, t_all)
        finally:
            run.bars.close()


def _plan(ds: Dataset, setup: Setup, folds: int, test_fraction: float, seed: int,
          jobs: int, bars: Bars) -> TrainingRun:
    """The folds that choose the model (and the held-out test set with ``folds`` 1)."""
    labels = ds.labels
    if folds > 1:
        sel = stratified_folds(labels, folds, seed)
        train_idx, test_idx = np.arange(len(labels)), np.zeros(0, np.intp)
    else:
        train_idx, test_idx = split_by_recording(labels, test_fraction, seed)
        require_test_set(test_idx)
        inner = min(3, int(np.bincount(labels[train_idx]).min()))
        sel = [train_idx[f] for f in stratified_folds(labels[train_idx], inner, seed)] \
            if inner >= 2 else []
    return TrainingRun(ds, setup, labels, sel, train_idx, test_idx, seed, jobs, bars)


def _cross_validate_candidates(run: TrainingRun, cands: list[Candidate], cnn_budget: float,
                               every_fold: bool = False) -> None:
    """The shared features, then every candidate's cross-validation, cheapest first (the
    CNN only within its budget; no time cap on its fits: a cap would make its result
    depend on the machine's load, the work rule bounds it instead). A candidate stops as
    soon as it can no longer change the choice (:mod:`.choice`; ``every_fold``: never)."""
    ds = run.ds
    t0 = time.perf_counter()
    run.bank = build_bank(run.setup, ds, cands, "clean",
                          run.bars("features (one spectrum per recording)", len(ds.items)),
                          run.jobs)
    run.timing["features_s"] = time.perf_counter() - t0
    n_fits = len(run.folds) + 1
    t0 = time.perf_counter()
    done = run.bars("first folds (L2 penalty chosen)", 1)
    first = prepare_first_folds(cands, [run.bank.view(c) for c in cands], run.labels,
                                run.folds, run.classes, run.seed, run.memo, run.jobs)
    done()
    # each one's share of that step (they ran side by side)
    first_s = {k: (time.perf_counter() - t0) * v / max(1e-9, sum(first.values()))
               for k, v in first.items()}
    for cand in list(cands):
        cw = run.bank.view(cand)
        if cand.name == "cnn" and len(cands) > 1:
            need = cnn_work(cw, n_fits)
            if need > cnn_budget:
                run.skipped["cnn"] = (f"projected work {need} window-epochs "
                                      f"({sum(len(w) for w in cw.train)} training windows x "
                                      f"{CNN_EPOCHS} epochs x {n_fits} fits) exceeds its "
                                      f"budget of {cnn_budget:g}")
                log.info("candidate cnn skipped: %s", run.skipped["cnn"])
                cands.remove(cand)
                continue
        t0 = time.perf_counter()
        rival = None if every_fold or not run.folds else must_exceed(run.results, cands)
        done = run.bars(f"cross-validation: {cand.name}", len(run.folds))
        if rival is not None:
            trial = cross_validate_against(cand, cw, run.labels, run.folds, run.classes,
                                           run.seed, run.oof[rival[0]], rival[1],
                                           jobs=run.jobs, memo=run.memo, done=done)
            ans = trial.answers
        else:
            trial = None
            ans = cross_validate(cand, cw, run.labels, run.folds, run.classes, run.seed,
                                 jobs=run.jobs, memo=run.memo, done=done,
                                 novelty=False) if run.folds else {}
        run.oof[cand.name] = ans
        run.results[cand.name] = _result(run, cand, ans, time.perf_counter() - t0
                                         + first_s.get(cand.name, 0.0))
        if trial is not None and trial.table is None:
            _stopped(run.results[cand.name], trial, rival, len(run.folds))
    run.cands = cands
    _complete_stopped(run)
    run.timing["cross_validation_s"] = sum(r["cross_validation_s"]
                                           for r in run.results.values())


def _result(run: TrainingRun, cand: Candidate, ans: dict, seconds: float) -> dict:
    """A candidate's entry of the report: its accuracy on the folds it ran and its costs."""
    cw = run.bank.view(cand)
    table = accuracy_by_time(ans, run.labels) if ans else {}
    return {"about": cand.about, "accuracy_by_time": table,
            "mean_accuracy": mean_accuracy(table) if ans else math.nan,
            "features_s": round(run.bank.seconds, 3) if cand.cols is not None else 0.0,
            "cross_validation_s": round(seconds, 3),
            "fit_s": [round(s, 3) for s in cand.fit_s],
            "inputs": int(cw.test[0].inputs.shape[1]) if len(cw.test[0]) else None}


def _stopped(res: dict, trial, rival: tuple[str, float], n_folds: int) -> None:
    """Mark a candidate's entry as stopped early: its accuracy by decision time covers the
    folds it ran; it takes no part in the choice (``mean_accuracy`` NaN)."""
    res.update(mean_accuracy=math.nan, mean_accuracy_folds_run=mean_accuracy(
        res["accuracy_by_time"]), folds_run=trial.folds_run,
        mean_accuracy_at_most=trial.bound, bound_certain=trial.sure)
    res["stopped"] = (f"at most {100 * trial.bound:.2f} % "
                      f"({trial.stopped_because(n_folds)}), while it had to exceed "
                      f"{100 * rival[1]:.2f} % ({rival[0]} plus the tie) to change the "
                      "choice")
    log.info("candidate stopped: %s", res["stopped"])


def _complete_stopped(run: TrainingRun) -> None:
    """Cross-validate on every fold each stopped candidate that could still change the
    choice (a costlier winner came after it: :func:`~.choice.could_change`), until none
    could (the folds it ran are reused from the memo)."""
    while True:
        todo = [c for c in run.cands if run.results[c.name].get("stopped")
                and could_change(run.results, run.cands, c.name)]
        if not todo:
            return
        cand = todo[0]
        t0 = time.perf_counter()
        done = run.bars(f"cross-validation: {cand.name} (completed)", len(run.folds))
        ans = cross_validate(cand, run.bank.view(cand), run.labels, run.folds, run.classes,
                             run.seed, jobs=run.jobs, memo=run.memo, done=done,
                             novelty=False)
        before = run.results[cand.name]["cross_validation_s"]
        run.oof[cand.name] = ans
        run.results[cand.name] = _result(run, cand, ans, before + time.perf_counter() - t0)
        run.results[cand.name]["completed"] = "stopped early, then completed: a costlier " \
            "winner came after it, and it might have tied that one"
        log.info("candidate %s completed after a costlier winner", cand.name)


def _mains_step(run: TrainingRun, chosen: str, mains_notch: bool | None) -> Candidate:
    """The mains notch: tried on the chosen candidate unless asked (:mod:`.mains_trial`).
    Returns the candidate to go on with (notched when adopted)."""
    cand = next(c for c in run.cands if c.name == chosen)
    t0 = time.perf_counter()
    if mains_notch is None:
        report, won = try_mains_notch(cand, run.setup, run.ds, run.labels, run.folds,
                                      run.oof[chosen], run.bank, run.seed, jobs=run.jobs,
                                      memo=run.memo, bars=run.bars)
        if won is not None:
            notched, run.setup, run.bank, run.oof[chosen] = won
            run.cands[run.cands.index(cand)] = cand = notched
            run.results[chosen]["mains_notch"] = True
            if run.oof[chosen]:  # no cross-validation (too few recordings): nothing to score
                table = accuracy_by_time(run.oof[chosen], run.labels)
                run.results[chosen].update(accuracy_by_time=table,
                                           mean_accuracy=mean_accuracy(table))
    else:
        report = {"adopted": mains_notch,
                  "why": f"{'on' if mains_notch else 'off'}: asked (not tried)"}
    run.results[chosen]["mains_notch_trial"] = report
    run.timing["mains_notch_s"] = time.perf_counter() - t0
    return cand


def _augmentation_step(run: TrainingRun, cand: Candidate, augment: AugmentConfig) -> dict:
    """The augmentation trial on the chosen candidate (:mod:`.augment_trial`)."""
    t0 = time.perf_counter()
    report, won = try_augmentation(cand, run.bank, run.ds, augment, run.seed, run.labels,
                                   run.folds, run.results[cand.name]["mean_accuracy"],
                                   run.oof[cand.name], jobs=run.jobs, memo=run.memo,
                                   progress=run.bars)
    if won is not None:
        run.bank, run.oof[cand.name] = won
    run.timing["augment_s"] = time.perf_counter() - t0
    return report


def _final_step(run: TrainingRun, cand: Candidate) -> Final:
    """Temperatures from the out-of-fold answers, the model fitted on every training
    recording, and the answers the evaluation scores."""
    cw = run.bank.view(cand)
    ans = add_novelty(run.oof[cand.name], cw, run.labels, run.folds, len(run.classes))
    temps = fold_temperatures(ans, run.labels, len(run.folds)) if ans else []
    t_final = fit_temperature(*at_times(ans, run.labels)) if ans else 1.0
    t0 = time.perf_counter()
    done = run.bars("final fit", 1)
    fitted = fit_final(cand, cw, run.labels, run.train_idx, run.classes, run.seed, run.memo,
                       run.jobs)
    novelty = novelty_on(cw, run.labels, run.train_idx, len(run.classes))
    novelty.threshold = novelty_threshold(ans)
    done()
    secs = time.perf_counter() - t0
    if len(run.test_idx):
        evaluated = {int(i): cooled(answers_of(fitted, cw.test[i], -1, novelty), t_final)
                     for i in run.test_idx if len(cw.test[i])}
    else:
        evaluated = calibrated(ans, temps) if ans else {}
    return Final(fitted, novelty, ans, temps, t_final, evaluated, secs)
