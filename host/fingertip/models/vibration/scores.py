"""Scores of cross-validated anytime answers: accuracy at each decision time, time to
decision, calibration (temperatures, ECE) and the novelty threshold of "unknown"."""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .anytime import DECISION_TIMES, at_time, time_label
from .reliability import apply_temperature, ece, fit_temperature

THRESHOLDS = (0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 0.98, 0.99, 0.995, 0.999)
TARGET_ACCURACY = 0.95
UNKNOWN_KEEP = 0.95
"""Share of known recordings (out of fold) whose answer must stay a class, not unknown."""
LASTED_TOL_S = 0.05
"""A recording whose last window ends this close to a decision time counts as lasting
that long (frames cannot reach the very last samples: a 1 s recording's last frame ends
at 0.997 s)."""


@dataclass
class Answers:
    """One recording's running probabilities (after each growing window) and their times."""

    probs: np.ndarray
    run: np.ndarray
    t_end: np.ndarray
    fold: int = -1
    dist: np.ndarray | None = None
    """Novelty distance of each window
    (:class:`~fingertip.models.vibration.reliability.Novelty`)."""


def best_case(part: dict[int, Answers], every: dict[int, Answers], labels: np.ndarray
              ) -> dict[int, Answers]:
    """``part``, completed with a right and certain answer for each recording of
    ``every`` it lacks (at the same times): scored, the most a cross-validation that
    ``part`` began can still reach."""
    out = dict(part)
    for i, a in every.items():
        if i not in out:
            sure = np.zeros_like(a.run)
            sure[:, labels[i]] = 1.0
            out[i] = Answers(sure, sure, a.t_end, a.fold)
    return out


STOP_Z = 3.0
"""A trial is stopped as likely lost when its mean accuracy's upper confidence bound at
this many standard errors (one-sided, about 0.13 % by the normal approximation) stays below
what it must reach: :func:`likely_at_most`."""
MIN_PAIRED = 30
"""Recordings a trial must have answered before :func:`likely_at_most` judges it."""


def _hits(a: Answers, label: int, times: Sequence[float | None]) -> list[float | None]:
    """Right (1) or wrong (0) at each of ``times``, as :func:`accuracy_by_time` counts it;
    None where the recording had not lasted that long."""
    out: list[float | None] = []
    for t in times:
        if t is not None and a.t_end[-1] < t - LASTED_TOL_S:
            out.append(None)
            continue
        q = at_time(a.run, a.t_end, t)
        out.append(float(q is not None and int(np.argmax(q)) == label))
    return out


def _paired(a: Answers, b: Answers, label: int, times: Sequence[float | None]) -> float:
    """The mean difference of ``a``'s hits and ``b``'s on one recording, over the times
    both count (two candidates' windows may end a frame apart: the CNN's own windows)."""
    d = [x - y for x, y in zip(_hits(a, label, times), _hits(b, label, times), strict=True)
         if x is not None and y is not None]
    return float(np.mean(d)) if d else 0.0


def likely_at_most(part: dict[int, Answers], every: dict[int, Answers], labels: np.ndarray,
                   z: float = STOP_Z, times: Sequence[float | None] = DECISION_TIMES
                   ) -> float:
    """An upper confidence bound of the mean accuracy (over the decision times) that a
    cross-validation begun with ``part`` will reach on every recording of ``every`` (the
    plain model's answers on the same folds), or inf when too few are answered to judge.

    The folds are a random partition, so the recordings still to come are a draw like
    those answered: the paired difference (``part``'s right answers minus ``every``'s on
    the same recordings) seen so far is the estimate of theirs, with the standard error of
    the difference between two such draws (from the per-recording differences). The bound
    is ``every``'s accuracy plus the difference seen plus ``z`` standard errors of what
    the rest could still change."""
    seen = [i for i in part if i in every]
    rest = len(every) - len(seen)
    if len(seen) < MIN_PAIRED or rest <= 0:
        return math.inf
    d = np.array([_paired(part[i], every[i], labels[i], times) for i in seen])
    diff = mean_accuracy(accuracy_by_time({i: part[i] for i in seen}, labels, times)) \
        - mean_accuracy(accuracy_by_time({i: every[i] for i in seen}, labels, times))
    se = float(np.std(d, ddof=1)) * math.sqrt(1 / len(seen) + 1 / rest)
    share_left = rest / len(every)
    return mean_accuracy(accuracy_by_time(every, labels, times)) + diff + share_left * z * se


def fold_temperatures(ans: dict[int, Answers], labels: np.ndarray, n_folds: int,
                      times: Sequence[float | None] = DECISION_TIMES) -> list[float]:
    """For each fold, the temperature fitted on the other folds' out-of-fold answers (at
    the decision times): every fold is then calibrated without seeing its own recordings."""
    out = []
    for f in range(n_folds):
        p, y = at_times({i: a for i, a in ans.items() if a.fold != f}, labels, times)
        out.append(fit_temperature(p, y))
    return out


def at_times(ans: dict[int, Answers], labels: np.ndarray,
             times: Sequence[float | None] = DECISION_TIMES) -> tuple[np.ndarray, np.ndarray]:
    """(probabilities, labels) of every recording's running answer at each of ``times``
    it reached."""
    ps, ys = [], []
    for i, a in ans.items():
        for t in times:
            q = at_time(a.run, a.t_end, t)
            if q is not None:
                ps.append(q)
                ys.append(labels[i])
    k = next(iter(ans.values())).run.shape[1] if ans else 0
    return np.array(ps).reshape(-1, k), np.array(ys, np.int64)


def calibrated(ans: dict[int, Answers], temps: Sequence[float]) -> dict[int, Answers]:
    """The answers with each fold's temperature applied (running probabilities too)."""
    out = {}
    for i, a in ans.items():
        t = temps[a.fold] if 0 <= a.fold < len(temps) else 1.0
        out[i] = Answers(apply_temperature(a.probs, t), apply_temperature(a.run, t),
                         a.t_end, a.fold, a.dist)
    return out


def cooled(a: Answers, t: float) -> Answers:
    """``a`` at temperature ``t``."""
    return Answers(apply_temperature(a.probs, t), apply_temperature(a.run, t), a.t_end,
                   a.fold, a.dist)


def accuracy_by_time(ans: dict[int, Answers], labels: np.ndarray,
                     times: Sequence[float | None] = DECISION_TIMES) -> dict[str, dict]:
    """Per decision time: accuracy over the recordings that lasted that long (per
    recording, the running answer at that time) and how many they were."""
    out = {}
    for t in times:
        hits = []
        for i, a in ans.items():
            if t is not None and a.t_end[-1] < t - LASTED_TOL_S:
                continue  # the recording ended before t: it has no answer *at* t
            q = at_time(a.run, a.t_end, t)
            hits.append(q is not None and int(np.argmax(q)) == labels[i])
        out[time_label(t)] = {"seconds": t, "accuracy": float(np.mean(hits)) if hits
                              else math.nan, "recordings": len(hits)}
    return out


def decision_curve(ans: dict[int, Answers], labels: np.ndarray,
                   thresholds: Sequence[float] = THRESHOLDS) -> list[dict]:
    """Per threshold: accuracy of the decisions (first running answer at or above it,
    else the last answer) and the median and 90th percentile time to decision."""
    from .anytime import decide

    out = []
    for th in thresholds:
        ok, ts, undecided = [], [], 0
        for i, a in ans.items():
            k = a.run.shape[1]
            d = decide(a.run, a.t_end, [str(j) for j in range(k)], th)
            ok.append(d.label is not None and int(d.label) == labels[i])
            ts.append(d.t)
            undecided += not d.decided
        out.append({"threshold": th, "accuracy": float(np.mean(ok)),
                    "median_s": float(np.median(ts)), "p90_s": float(np.percentile(ts, 90)),
                    "undecided": undecided})
    return out


def time_to_decision(curve: list[dict], target: float = TARGET_ACCURACY) -> dict:
    """The lowest threshold whose decisions are ``target`` accurate, and its median time
    (None when no threshold reaches it)."""
    for row in curve:
        if row["accuracy"] >= target:
            return {"target_accuracy": target, **row}
    return {"target_accuracy": target, "threshold": None, "accuracy": None,
            "median_s": None, "p90_s": None, "undecided": None}


def ece_of(ans: dict[int, Answers], labels: np.ndarray,
           times: Sequence[float | None] = DECISION_TIMES) -> tuple[float, np.ndarray,
                                                                     np.ndarray]:
    """(ECE, confidence, correct) of the running answers at the decision times."""
    p, y = at_times(ans, labels, times)
    if not len(p):
        return 0.0, np.zeros(0), np.zeros(0, bool)
    conf = p.max(axis=1)
    ok = p.argmax(axis=1) == y
    return ece(conf, ok), conf, ok


def mean_accuracy(table: dict[str, dict]) -> float:
    v = [r["accuracy"] for r in table.values() if r["recordings"] and
         math.isfinite(r["accuracy"])]
    return float(np.mean(v)) if v else math.nan


def novelty_threshold(ans: dict[int, Answers]) -> float:
    """The novelty distance that :data:`UNKNOWN_KEEP` of the known recordings' final
    answers (out of fold) stay below."""
    d = [a.dist[-1] for a in ans.values() if a.dist is not None and len(a.dist)]
    return float(np.quantile(d, UNKNOWN_KEEP)) if d else math.inf
