"""Cross-validation by recording of the material candidates: every fit paid once.

:func:`cross_validate` gives every recording's out-of-fold running probabilities. Its folds
run in parallel on the machine's cores (:mod:`.parallel`); a candidate whose first fit fixes
a choice (the logistic regressions' L2 penalty) runs its first fold alone, so that every
fold sees the same choice whatever the number of cores. Fits are remembered by what they
were fitted on (:class:`FitMemo`: the candidate, the features, the training recordings, the
seed): the ensemble's members are the baseline's, the linear candidate's and the MLP's
models of the same folds, reused, not refitted. :func:`cross_validate_against` stops a
trial as soon as it cannot reach the accuracy it must (:func:`~.scores.best_case`).
"""
from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from .bank import CandidateWindows, _Columns
from .candidates import CNN_EPOCHS, Candidate, Fitted, _local, as_fitted
from .classify import Dataset, DatasetError, Windows, stratified_folds
from .parallel import run_rounds, shared
from .reliability import Novelty, apply_temperature
from .scores import (
    STOP_Z,
    UNKNOWN_KEEP,
    Answers,
    accuracy_by_time,
    best_case,
    calibrated,
    fold_temperatures,
    likely_at_most,
    mean_accuracy,
)

log = logging.getLogger(__name__)


class FitMemo:
    """Fitted models by (candidate, features token, training recordings, seed), with the
    seconds each fit took."""

    def __init__(self) -> None:
        self._fits: dict[tuple, tuple[object, float]] = {}

    @staticmethod
    def key(name: str, token: str, idx: np.ndarray, seed: int) -> tuple:
        return name, token, np.asarray(idx, np.intp).tobytes(), int(seed)

    def get(self, key: tuple) -> tuple[object, float] | None:
        return self._fits.get(key) if key[1] else None  # no token: never shared

    def put(self, key: tuple, model: object, seconds: float) -> None:
        if key[1]:
            self._fits[key] = (model, seconds)

    def __len__(self) -> int:
        return len(self._fits)


def training_rows(cw: CandidateWindows, labels: np.ndarray, idx: np.ndarray, k: int
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(inputs, labels, recording) of the training windows of recordings ``idx``."""
    ws = [(i, cw.train[i]) for i in idx]
    ws = [(i, w) for i, w in ws if len(w)]
    if not ws:
        raise DatasetError("no training windows (recordings too short?)")
    x = np.concatenate([w.inputs for _, w in ws])
    y = np.concatenate([np.full(len(w), labels[i]) for i, w in ws])
    g = np.concatenate([np.full(len(w), i) for i, w in ws])
    if len(np.unique(y)) < k:
        raise DatasetError("some class has no training window (recordings too short?)")
    return x, y, g


def fit_on(cand: Candidate, cw: CandidateWindows, labels: np.ndarray, idx: np.ndarray,
           classes: list[str], seed: int) -> Fitted:
    x, y, g = training_rows(cw, labels, idx, len(classes))
    return cand.train(x, y, g, classes, seed)


def novelty_on(cw: CandidateWindows, labels: np.ndarray, idx: np.ndarray, k: int
               ) -> Novelty:
    """The novelty model of the training windows of ``idx`` (each recording weighs the
    same)."""
    x, y, g = training_rows(cw, labels, idx, k)
    _, inv, counts = np.unique(g, return_inverse=True, return_counts=True)
    return Novelty.fit(x, y, k, 1.0 / counts[inv])


def add_novelty(ans: dict[int, Answers], cw: CandidateWindows, labels: np.ndarray,
                folds: list[np.ndarray], k: int) -> dict[int, Answers]:
    """Out-of-fold answers with the novelty distance of each window, from the novelty
    model of its fold's training recordings (what :func:`cross_validate` gives with
    ``novelty``, computed for the chosen candidate only)."""
    if not ans:
        return {}
    pool = np.concatenate(folds)
    out = dict(ans)
    for te in folds:
        mine = [int(i) for i in te if int(i) in ans]
        if not mine:
            continue
        nov = novelty_on(cw, labels, np.setdiff1d(pool, te), k)
        for i in mine:
            out[i] = replace(ans[i], dist=nov.distance(cw.test[i].inputs))
    return out


def answers_of(fitted: Fitted, w: Windows, fold: int = -1,
               novelty: Novelty | None = None) -> Answers:
    from .anytime import running

    p = fitted.forward(w.inputs)
    return Answers(p, running(p, w.growing), w.t_end, fold,
                   None if novelty is None else novelty.distance(w.inputs))


def _member_windows(cand: Candidate, cw: CandidateWindows, member: Candidate
                    ) -> CandidateWindows:
    cols = _local(cand, member)
    return CandidateWindows(_Columns(cw.train, cols), _Columns(cw.test, cols), cw.seconds,
                            cw.token)


def _fit_job(name: str, idx: np.ndarray, seed: int) -> tuple[object, float]:
    """In a worker: fit the shared candidate ``name`` on recordings ``idx``."""
    cand, cw, labels, classes = shared("fit")[name]
    t0 = time.perf_counter()
    m = fit_on(cand, cw, labels, idx, classes, seed)
    return m.model, time.perf_counter() - t0


def _fold_job(f: int, tr: np.ndarray, te: np.ndarray, model: object | None
              ) -> tuple[int, object, float, dict[int, Answers]]:
    """In a worker: one fold (fitted here unless ``model`` is given), its answers."""
    cand, cw, labels, classes, seed, novelty = shared("fold")
    t0 = time.perf_counter()
    m = fit_on(cand, cw, labels, tr, classes, seed) if model is None else as_fitted(model)
    secs = time.perf_counter() - t0
    nov = novelty_on(cw, labels, tr, len(classes)) if novelty else None
    ans = {int(i): answers_of(m, cw.test[i], f, nov) for i in te if len(cw.test[i])}
    return f, m.model, secs, ans


def prepare_first_folds(cands: list[Candidate], cws: list[CandidateWindows],
                        labels: np.ndarray, folds: list[np.ndarray], classes: list[str],
                        seed: int, memo: FitMemo, jobs: int = 1) -> dict[str, float]:
    """The first fold of every candidate whose first fit fixes a choice (the logistic
    regressions' L2 penalty), fitted side by side in workers, remembered in ``memo`` and
    its choice kept by the candidate: each then cross-validates all its folds at once.
    Returns the seconds of each of those fits."""
    todo = [(c, cw) for c, cw in zip(cands, cws, strict=True)
            if c.first_alone and not c.members]
    if not folds or not todo:
        return {}
    train0 = np.setdiff1d(np.concatenate(folds), folds[0])
    share = {c.name: (c, cw, labels, classes) for c, cw in todo}
    got = run_rounds(_fit_job, [(c.name, train0, seed) for c, _ in todo], jobs,
                     {"fit": share})
    out = {}
    for (c, cw), (model, secs) in zip(todo, got, strict=True):
        memo.put(memo.key(c.name, cw.token, train0, seed), model, secs)
        c.fit.keep(model)
        out[c.name] = secs
    return out


def fit_members(cand: Candidate, cw: CandidateWindows, labels: np.ndarray,
                trains: list[np.ndarray], classes: list[str], seed: int, memo: FitMemo,
                jobs: int = 1) -> list[list[tuple[object, float]]]:
    """Per training set of ``trains``: the (model, seconds) of each member of the
    composite ``cand``, from ``memo`` when fitted already, else fitted (in parallel) and
    remembered."""
    names = {}
    todo: list[tuple[int, int, tuple]] = []
    for t, tr in enumerate(trains):
        for j, (m, off) in enumerate(cand.members):
            key = memo.key(m.name, cw.token, tr, seed + off)
            names[m.name] = (m, _member_windows(cand, cw, m), labels, classes)
            if memo.get(key) is None and key not in [k for *_, k in todo]:
                todo.append((t, j, key))
    # a member whose first fit fixes a choice (the L2 penalty) makes it here, alone
    first = {}
    for t, j, key in todo:
        m, off = cand.members[j]
        if m.first_alone and m.name not in first:
            first[m.name] = key
            t0 = time.perf_counter()
            fitted = fit_on(m, names[m.name][1], labels, trains[t], classes, seed + off)
            memo.put(key, fitted.model, time.perf_counter() - t0)
    todo = [(t, j, key) for t, j, key in todo if memo.get(key) is None]
    args = [(cand.members[j][0].name, trains[t], seed + cand.members[j][1])
            for t, j, _ in todo]
    for (_, _, key), (model, secs) in zip(todo, run_rounds(_fit_job, args, jobs,
                                                           {"fit": names}), strict=True):
        memo.put(key, model, secs)
    return [[memo.get(memo.key(m.name, cw.token, tr, seed + off))
             for m, off in cand.members] for tr in trains]


TRIAL_ROUND = 2
"""New fits per round of a cross-validation that may stop (a trial, a costlier candidate):
it is asked whether to go on after each round, the same rounds whatever the number of
workers (so that its decision never depends on them; two fits fill this machine's two
cores). A round is as many consecutive folds as need two new fits (:func:`fold_rounds`):
two folds of a plain candidate, one fold of a trial of the ensemble (its four members are
all refitted), three where the first fold's fit is remembered already (the logistic
regressions' first folds, fitted where they choose their penalty)."""


def fold_rounds(cand: Candidate, cw: CandidateWindows, trains: list[np.ndarray], seed: int,
                memo: FitMemo, may_stop: bool) -> list[list[int]]:
    """The rounds the folds (``trains``: their training recordings) run in: all at once,
    or, when the cross-validation may stop, consecutive folds until the fits not yet in
    ``memo`` (a composite's members') make :data:`TRIAL_ROUND` (a fold already fitted
    costs only its answers and joins the next)."""
    if not may_stop:
        return [list(range(len(trains)))] if trains else []
    parts = cand.members or ((cand, 0),)
    rounds: list[list[int]] = []
    now: list[int] = []
    fits = 0
    for f, tr in enumerate(trains):
        now.append(f)
        fits += sum(memo.get(memo.key(m.name, cw.token, tr, seed + off)) is None
                    for m, off in parts)
        if fits >= TRIAL_ROUND:
            rounds.append(now)
            now, fits = [], 0
    return rounds + [now] if now else rounds


def cross_validate(cand: Candidate, cw: CandidateWindows, labels: np.ndarray,
                   folds: list[np.ndarray], classes: list[str], seed: int,
                   stop: Callable[[dict[int, Answers]], bool] | None = None, *,
                   jobs: int = 1, memo: FitMemo | None = None,
                   done: Callable[[], None] | None = None,
                   novelty: bool = True) -> dict[int, Answers]:
    """Out-of-fold answers of every recording of ``folds`` (test sets; each fold's model
    is trained on the recordings of the other folds; ``jobs`` folds run at a time).
    ``stop``: asked after each round of folds (:func:`fold_rounds`) with the answers so
    far; True ends the cross-validation there (the answers returned are then those of the
    folds run).
    ``memo``: fits made already (and where this one's go); ``done``: called per fold.
    ``novelty``: each answer's novelty distance too (False: left None, :func:`add_novelty`
    gives it to the answers of the candidate finally chosen; the others never need it)."""
    memo = FitMemo() if memo is None else memo
    pool = np.concatenate(folds)
    trains = [np.setdiff1d(pool, te) for te in folds]
    if cand.members:
        return _cross_validate_composite(cand, cw, labels, folds, trains, classes, seed,
                                         stop, jobs, memo, done, novelty)
    models: list[object | None] = [None] * len(folds)
    secs = [0.0] * len(folds)
    for f, tr in enumerate(trains):
        hit = memo.get(memo.key(cand.name, cw.token, tr, seed))
        if hit is not None:
            models[f], secs[f] = hit
    share = {"fold": (cand, cw, labels, classes, seed, novelty)}
    results: list[tuple] = []

    def answers(rs: list[tuple]) -> dict[int, Answers]:
        out: dict[int, Answers] = {}
        for _, _, _, a in rs:
            out.update(a)
        return out

    for fs in fold_rounds(cand, cw, trains, seed, memo, stop is not None):
        if cand.first_alone and models[fs[0]] is None:  # it fixes a choice: alone, first
            results.append(run_rounds(_fold_job, [(fs[0], trains[fs[0]], folds[fs[0]],
                                                   None)], 1, share)[0])
            if done is not None:
                done()
            fs = fs[1:]
        results += run_rounds(_fold_job, [(f, trains[f], folds[f], models[f]) for f in fs],
                              jobs, share, done=done)
        if stop is not None and len(results) < len(folds) and stop(answers(results)):
            break
    for f, model, s, _ in results:
        if models[f] is None:
            memo.put(memo.key(cand.name, cw.token, trains[f], seed), model, s)
            secs[f] = s
    last_f, last_model = results[-1][0], results[-1][1]
    cand.last, cand.last_fit_s = as_fitted(last_model), secs[last_f]
    cand.fit_s = [secs[r[0]] for r in results]
    if len(results) < len(folds):
        log.info("cross-validation of %s stopped after %d of %d folds", cand.name,
                 len(results), len(folds))
    return answers(results)


def _cross_validate_composite(cand: Candidate, cw: CandidateWindows, labels: np.ndarray,
                              folds: list[np.ndarray], trains: list[np.ndarray],
                              classes: list[str], seed: int,
                              stop: Callable[[dict[int, Answers]], bool] | None, jobs: int,
                              memo: FitMemo, done: Callable[[], None] | None,
                              novelty: bool) -> dict[int, Answers]:
    """:func:`cross_validate` of a composite: its members fitted (or found in ``memo``)
    a round of folds at a time (:func:`fold_rounds`), so that ``stop`` can end it
    between rounds like any other candidate's (a trial of the ensemble would otherwise fit
    every fold's members first)."""
    out: dict[int, Answers] = {}
    secs: list[float] = []
    last = None
    for fs in fold_rounds(cand, cw, trains, seed, memo, stop is not None):
        parts = fit_members(cand, cw, labels, [trains[f] for f in fs], classes, seed, memo,
                            jobs)
        for f, p in zip(fs, parts, strict=True):
            last = as_fitted(cand.combine([m for m, _ in p], classes))
            secs.append(sum(s for _, s in p))
            nov = novelty_on(cw, labels, trains[f], len(classes)) if novelty else None
            out.update({int(i): answers_of(last, cw.test[i], f, nov) for i in folds[f]
                        if len(cw.test[i])})
            if done is not None:
                done()
        if stop is not None and fs[-1] < len(folds) - 1 and stop(out):
            log.info("cross-validation of %s stopped after %d of %d folds", cand.name,
                     fs[-1] + 1, len(folds))
            break
    cand.last, cand.last_fit_s, cand.fit_s = last, secs[-1], secs
    return out


def fit_final(cand: Candidate, cw: CandidateWindows, labels: np.ndarray, idx: np.ndarray,
              classes: list[str], seed: int, memo: FitMemo | None = None, jobs: int = 1
              ) -> Fitted:
    """``cand`` fitted on recordings ``idx`` (a composite's members in parallel, and from
    ``memo`` when fitted already)."""
    memo = FitMemo() if memo is None else memo
    if cand.members:
        parts = fit_members(cand, cw, labels, [np.asarray(idx)], classes, seed, memo, jobs)
        return as_fitted(cand.combine([m for m, _ in parts[0]], classes))
    key = memo.key(cand.name, cw.token, idx, seed)
    hit = memo.get(key)
    if hit is not None:
        return as_fitted(hit[0])
    t0 = time.perf_counter()
    fitted = fit_on(cand, cw, labels, idx, classes, seed)
    memo.put(key, fitted.model, time.perf_counter() - t0)
    return fitted


@dataclass
class Trial:
    """A variant of a candidate cross-validated against the mean accuracy it must reach."""

    answers: dict[int, Answers]
    """Out-of-fold answers of the folds run."""
    folds_run: int
    table: dict[str, dict] | None
    """Accuracy by decision time when every fold ran; None when it stopped early."""
    bound: float | None
    """When stopped early: the most its mean accuracy could still have reached (``sure``),
    or its upper confidence bound (:func:`~.scores.likely_at_most`)."""
    sure: bool = True
    """Stopped by the certain bound (every recording to come counted right), not by the
    confidence bound."""

    @property
    def accuracy(self) -> float | None:
        return None if self.table is None else mean_accuracy(self.table)

    def stopped_because(self, n_folds: int) -> str:
        """Why it stopped, for the report (when it did)."""
        how = "the others counted right" if self.sure else \
            (f"the others expected like these: the upper bound at {STOP_Z:g} standard "
             "errors of the paired difference")
        return f"after {self.folds_run} of {n_folds} folds, {how}"


def cross_validate_against(cand: Candidate, cw: CandidateWindows, labels: np.ndarray,
                           folds: list[np.ndarray], classes: list[str], seed: int,
                           clean: dict[int, Answers], need: float, *, jobs: int = 1,
                           memo: FitMemo | None = None,
                           done: Callable[[], None] | None = None) -> Trial:
    """Cross-validate ``cand`` (windows ``cw``) on ``folds`` to be compared with ``need``,
    a mean accuracy over the decision times. After each round of folds
    (:func:`fold_rounds`) it stops when even right answers on every recording of
    ``clean`` (the plain model's answers) still to come could not reach ``need`` (then
    the remaining folds could not change the decision), or when, with the recordings to
    come answered as those answered so far, it would not reach ``need`` with
    :data:`~.scores.STOP_Z` standard errors to spare (:func:`~.scores.likely_at_most`:
    the remaining folds would change the decision about once in a thousand trials)."""
    why: dict[str, float | bool] = {}

    def lost(part: dict[int, Answers]) -> bool:
        sure = mean_accuracy(accuracy_by_time(best_case(part, clean, labels), labels))
        if sure < need:
            why.update(bound=sure, sure=True)
            return True
        likely = likely_at_most(part, clean, labels)
        if likely < need:
            why.update(bound=likely, sure=False)
            return True
        return False

    ans = cross_validate(cand, cw, labels, folds, classes, seed, stop=lost, jobs=jobs,
                         memo=memo, done=done, novelty=False)
    run = len({a.fold for a in ans.values()})
    if run < len(folds):
        return Trial(ans, run, None, float(why["bound"]), bool(why["sure"]))
    return Trial(ans, len(folds), accuracy_by_time(ans, labels), None)


def cnn_work(cw: CandidateWindows, n_fits: int, epochs: int = CNN_EPOCHS) -> int:
    """Projected work of the CNN candidate's training in window-epochs: its training
    windows of every recording x ``epochs`` x ``n_fits`` (the folds and the final model).
    An upper bound (a fold trains on fewer recordings; early stopping usually ends sooner)
    that depends on the data only, never on the machine."""
    return sum(len(w) for w in cw.train) * epochs * n_fits


def unknown_auroc(cand: Candidate, cw: CandidateWindows, ds: Dataset, left_out: str,
                  k: int = 5, seed: int = 0) -> dict:
    """Leave class ``left_out`` out of training: a ``k``-fold cross-validation on the other
    classes, whose fold models also answer every recording of ``left_out``. Returns the ROC
    AUC of the novelty distance (:class:`~fingertip.models.vibration.reliability.Novelty`,
    the last window) of the left-out recordings (answered by every fold model: k answers
    each) against the known ones (out of fold), the same for the softmax's own score
    (1 - top calibrated probability), and the share of each answered "unknown" at the
    trainer's rule (above the distance 95 % of known recordings stay below)."""
    from .reliability import auroc, unknown_score

    c_out = ds.classes.index(left_out)
    labels_all = ds.labels
    known = np.flatnonzero(labels_all != c_out)
    gone = np.flatnonzero(labels_all == c_out)
    classes = [c for c in ds.classes if c != left_out]
    labels = np.where(labels_all > c_out, labels_all - 1, labels_all)
    folds = [known[f] for f in stratified_folds(labels[known], k, seed)]
    ans: dict[int, Answers] = {}
    foreign: list[Answers] = []
    for f, te in enumerate(folds):
        tr = np.setdiff1d(known, te)
        m = fit_on(cand, cw, labels, tr, classes, seed)
        nov = novelty_on(cw, labels, tr, len(classes))
        for i in te:
            if len(cw.test[i]):
                ans[int(i)] = answers_of(m, cw.test[i], f, nov)
        foreign += [answers_of(m, cw.test[i], f, nov) for i in gone if len(cw.test[i])]
    temps = fold_temperatures(ans, labels, len(folds))
    known_d = np.array([a.dist[-1] for a in ans.values()])
    out_d = np.array([a.dist[-1] for a in foreign])
    known_p = unknown_score(np.array([a.run[-1] for a in calibrated(ans, temps).values()]))
    out_p = unknown_score(np.array([apply_temperature(a.run[-1], temps[a.fold])
                                    for a in foreign]))
    level = float(np.quantile(known_d, UNKNOWN_KEEP))
    return {"left_out": left_out, "auroc": auroc(out_d, known_d),
            "auroc_softmax": auroc(out_p, known_p),
            "known_recordings": len(known_d), "left_out_answers": len(out_d),
            "left_out_answered_unknown": float(np.mean(out_d > level)),
            "known_answered_unknown": float(np.mean(known_d > level))}
