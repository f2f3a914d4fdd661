"""The trainer's trial of augmentation (:mod:`.augment`): the chosen candidate
cross-validated again with augmented copies of its training recordings.

The augmentation is kept unless it costs more than :data:`~.candidates.TIE` of mean
accuracy on the (never augmented) held-out recordings: robustness to other days is taken
when it is free on the user's own data, and the report says what it costs when it is not.
When the full draw (speed, hum, motor) is not adopted, its speed part alone
(:meth:`~.augment.AugmentConfig.speed_only`) is tried by the same rule: on the simulated
slides the added noises cost a linear model 2-3 points while a change of speed alone cost
0.3 and still lifted slow slides from 29 % to 54 % (docs/classifiers.md). A trial stops as
soon as it cannot be adopted (:func:`~.cross_validation.cross_validate_against`). The
copies' features are computed once per setting and shared by every fold (:mod:`.bank`).
"""
from __future__ import annotations

import logging
import math
from collections.abc import Callable

import numpy as np

from .augment import AugmentConfig
from .bank import Bank, with_copies
from .candidates import TIE, Candidate
from .classify import Dataset
from .cross_validation import FitMemo, cross_validate_against
from .scores import Answers

log = logging.getLogger(__name__)


def try_augmentation(cand: Candidate, bank: Bank, ds: Dataset, augment: AugmentConfig,
                     seed: int, labels: np.ndarray, folds: list[np.ndarray], base: float,
                     clean: dict[int, Answers], *, jobs: int = 1, memo: FitMemo | None = None,
                     progress: Callable[[str, int], Callable[[], None]] | None = None
                     ) -> tuple[dict, tuple[Bank, dict[int, Answers]] | None]:
    """Returns the report's entry and, when adopted, the augmented bank and the
    candidate's out-of-fold answers with it (None otherwise). ``base``: the candidate's
    mean accuracy without; ``clean``: its out-of-fold answers without."""
    out = {"settings": augment.to_dict(), "adopted": False,
           "rule": f"adopted unless the cross-validated mean accuracy drops by more than "
                   f"{100 * TIE:g} points; when the full draw is not adopted, its speed "
                   f"part alone is tried by the same rule; a trial stops as soon as it can "
                   f"no longer be adopted"}
    if not augment.copies or not folds or not math.isfinite(base):
        out["why"] = "no augmentation asked" if not augment.copies else \
            "too few recordings to cross-validate it"
        return out, None
    tried: list[dict] = []
    won = None
    for cfg, what in ((augment, "augmentation"), (augment.speed_only(), "speed augmentation")):
        if tried and (cfg == augment or not augment.p_speed):
            break  # nothing but speed (already tried), or speed turned off by the caller
        one, won = trial_one(cand, bank, ds, cfg, seed, labels, folds, base, clean, what,
                             jobs, memo, progress)
        tried.append(one)
        if one["adopted"]:
            break
    out.update({k: v for k, v in tried[-1].items() if k != "what"})
    out["why"] = "; ".join(t["why"] for t in tried)
    if len(tried) > 1:
        out["tried"] = tried
    return out, won


def trial_one(cand: Candidate, bank: Bank, ds: Dataset, augment: AugmentConfig, seed: int,
              labels: np.ndarray, folds: list[np.ndarray], base: float,
              clean: dict[int, Answers], what: str, jobs: int, memo: FitMemo | None,
              progress: Callable[[str, int], Callable[[], None]] | None
              ) -> tuple[dict, tuple[Bank, dict[int, Answers]] | None]:
    """One draw (``augment``) cross-validated against the answers without it: the report's
    entry, and the features and answers with the copies when it is adopted (None otherwise)."""
    out: dict = {"settings": augment.to_dict(), "what": what}
    done = progress(f"{what}: copies", len(ds.items)) if progress else None
    more = with_copies(bank, ds, augment, seed, [cand], done, jobs)
    done = progress(f"{what}: folds", len(folds)) if progress else None
    trial = cross_validate_against(cand, more.view(cand), labels, folds, ds.classes, seed,
                                   clean, base - TIE, jobs=jobs, memo=memo, done=done)
    if trial.table is None:
        bound = trial.bound
        out.update({"mean_accuracy_without": base, "mean_accuracy_with": None,
                    "mean_accuracy_with_at_most": bound, "folds_run": trial.folds_run,
                    "bound_certain": trial.sure, "adopted": False})
        out["why"] = (f"{cand.name} with {what}: at most {100 * bound:.2f} % "
                      f"({trial.stopped_because(len(folds))}) against {100 * base:.2f} % "
                      "without: not adopted")
        log.info("%s", out["why"])
        return out, None
    acc = trial.accuracy
    out.update({"mean_accuracy_without": base, "mean_accuracy_with": acc,
                "accuracy_by_time_with": trial.table, "folds_run": trial.folds_run,
                "adopted": bool(acc >= base - TIE)})
    out["why"] = (f"{cand.name} with {what}: {100 * acc:.2f} % against "
                  f"{100 * base:.2f} % without: " + ("adopted" if out["adopted"] else
                                                     "not adopted"))
    log.info("%s", out["why"])
    return out, (more, trial.answers) if out["adopted"] else None
