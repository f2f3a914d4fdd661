"""The trainer's trial of the mains notch (:mod:`.mains`): on by default where the user's
own recordings show it costs nothing.

Notching steady 50/60 Hz lines makes a model hold up when the hum changes from one day to
the next, but it also removes what the hum told the model: with gain-free features, a
steady hum is a level reference, and a quiet texture stands closer to it than a loud one
(on the simulator the notch costs 0.7 points of clean accuracy, all of them copper tape
taken for wax paper, the two quietest materials, whose hum lines it removes). Whether that
reference is worth more than the robustness is a property of the data, so the trainer asks
the data: when some training recording carries steady mains lines, the chosen candidate is
cross-validated again with the notch on the same folds, and the notch is kept unless the
mean accuracy over the decision times drops by more than :data:`~.candidates.TIE` (0.5
points), the rule the augmentation trial follows: robustness is taken when it is free
within the cross-validation's noise. (The rule was "at least as high" until 2026-11-27: on
half of the real drum hits the ensemble lost 0.18 points with the notch, one answer in 142
recordings x 5 decision times, and without it hum added to the held-out hits took them from
97.9 % to 77.1 %.) When no recording carries lines, the notch changes no
training recording (same features, same model), so it is kept without a trial: it costs
nothing on the user's data and acts only when hum appears later.
"""
from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from . import mains
from .bank import Bank, build_bank, per_recording
from .candidates import TIE, Candidate
from .classify import Dataset, FeaturePipeline
from .cross_validation import FitMemo, cross_validate_against
from .scores import Answers, accuracy_by_time, mean_accuracy
from .setup import Setup

log = logging.getLogger(__name__)


def mains_lines_of(ds: Dataset, jobs: int = 1, done: Callable[[], None] | None = None
                   ) -> list[list[float]]:
    """The steady mains lines of every recording of ``ds`` (its own spectrum:
    :func:`~.mains.find_mains_lines`), on ``jobs`` worker processes."""

    def one(i: int) -> list[float]:
        rec = ds.items[i].rec
        return mains.find_mains_lines(np.asarray(rec.samples), rec.rate)

    return per_recording("mains", one, len(ds.items), jobs, done)


def recordings_with_lines(ds: Dataset, jobs: int = 1) -> list[int]:
    """Indices of the recordings of ``ds`` whose own spectrum shows steady mains lines."""
    return [i for i, lines in enumerate(mains_lines_of(ds, jobs)) if lines]


def try_mains_notch(cand: Candidate, setup: Setup, ds: Dataset, labels: np.ndarray,
                    folds: list[np.ndarray], clean: dict[int, Answers], bank: Bank,
                    seed: int, *, jobs: int = 1,
                    memo: FitMemo | None = None, bars=None
                    ) -> tuple[dict, tuple[Candidate, Setup, Bank, dict[int, Answers]] | None]:
    """Cross-validate ``cand`` again with the notch (``clean`` and ``bank``: its
    out-of-fold answers and the shared features without, on the same ``folds``).

    Returns the report's entry and, when the notch is adopted, the notched candidate, the
    setup, the features and its out-of-fold answers (None otherwise). The folds stop as
    soon as even right answers on every recording left could not reach the accuracy
    without."""
    t0 = time.perf_counter()
    base = mean_accuracy(accuracy_by_time(clean, labels)) if clean else math.nan
    out: dict = {"adopted": False, "rule": "tried when some training recording carries "
                 "steady mains lines; adopted unless the cross-validated mean accuracy "
                 f"drops by more than {100 * TIE:g} points; kept without a trial when no "
                 "recording carries lines (it changes none of them)"}
    # each recording searched once: the notched features below reuse what is found here
    lines = mains_lines_of(ds, jobs, bars("mains notch: lines", len(ds.items))
                           if bars else None)
    with_lines = [i for i, found in enumerate(lines) if found]
    out["recordings_with_lines"] = len(with_lines)
    notched_setup = replace(setup, cfg=replace(setup.cfg, mains_notch=True))
    if not with_lines:
        # the notch leaves every training recording as it is: the same windows, the same
        # answers, the same fits; what changes is only what the model does with hum at
        # run time, so the candidate goes on with its features' notch turned on
        out.update(adopted=True, why="no training recording carries steady mains lines: "
                   "the notch changes none of them, kept without a trial (it acts only on "
                   "hum that appears later)")
        out["seconds"] = round(time.perf_counter() - t0, 3)
        log.info("%s", out["why"])
        notched = replace(cand, pipe=FeaturePipeline(replace(cand.pipe.cfg, mains_notch=True),
                                                     cand.pipe.spec))
        return out, (notched, notched_setup, bank, clean)
    if not folds or not math.isfinite(base):
        out["why"] = "too few recordings to cross-validate it"
        out["seconds"] = round(time.perf_counter() - t0, 3)
        return out, None
    # the same candidate on notched features: its fits keep the choices its own
    # cross-validation made (the L2 penalty), as the augmentation trial's do
    notched = replace(cand, pipe=FeaturePipeline(replace(cand.pipe.cfg, mains_notch=True),
                                                 cand.pipe.spec), fit_s=[])
    # only the recordings with lines change: the others keep their clean windows
    done = bars("mains notch: features", len(with_lines)) if bars else None
    nb = build_bank(notched_setup, ds, [notched], "notched", done, jobs, lines=lines,
                    clean=bank)
    done = bars("mains notch: folds", len(folds)) if bars else None
    trial = cross_validate_against(notched, nb.view(notched), labels, folds, ds.classes,
                                   seed, clean, base - TIE, jobs=jobs, memo=memo, done=done)
    out["seconds"] = round(time.perf_counter() - t0, 3)
    if trial.table is None:
        bound = trial.bound
        out.update({"mean_accuracy_without": base, "mean_accuracy_with_at_most": bound,
                    "folds_run": trial.folds_run, "bound_certain": trial.sure})
        out["why"] = (f"{cand.name} with the mains notch: at most {100 * bound:.2f} % "
                      f"({trial.stopped_because(len(folds))}) against {100 * base:.2f} % "
                      f"without: not adopted ({len(with_lines)} recordings carry lines)")
        log.info("%s", out["why"])
        return out, None
    acc = trial.accuracy
    adopted = bool(acc >= base - TIE)
    out.update({"mean_accuracy_without": base, "mean_accuracy_with": acc,
                "folds_run": len(folds), "adopted": adopted})
    out["why"] = (f"{cand.name} with the mains notch: {100 * acc:.2f} % against "
                  f"{100 * base:.2f} % without ({len(with_lines)} recordings carry lines): "
                  + ("adopted" if adopted else "not adopted"))
    log.info("%s", out["why"])
    return out, (notched, notched_setup, nb, trial.answers) if adopted else None
