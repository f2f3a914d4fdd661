"""Which candidate the material trainer keeps, and when a candidate's cross-validation may
stop because it can no longer change that choice.

The rule (:func:`choose`): the cheapest candidate within :data:`~.candidates.TIE` of the
best mean accuracy over the decision times wins (candidates are listed cheapest first), so
a costlier candidate must beat a cheaper one by more than the tie. Candidates are
cross-validated cheapest first; a costlier one whose accuracy cannot exceed the candidate
chosen so far by more than the tie (:func:`must_exceed`) cannot change the choice, and its
cross-validation may stop (:func:`~.cross_validation.cross_validate_against`, the bound the
trials use). Such a candidate is reported with the folds it ran and its bound, and takes
no part in the choice. A later, costlier winner can raise the best so far that a stopped
candidate, cheaper than it, might have tied it: :func:`could_change` says when, and the
trainer then completes that candidate's cross-validation (:mod:`.material`).
"""
from __future__ import annotations

import math
from collections.abc import Sequence

from .candidates import TIE, Candidate


def scored(results: dict[str, dict]) -> dict[str, float]:
    """The mean accuracies of the candidates cross-validated on every fold."""
    return {k: v["mean_accuracy"] for k, v in results.items()
            if v.get("mean_accuracy") is not None and math.isfinite(v["mean_accuracy"])}


def choose(results: dict[str, dict], cands: Sequence[Candidate]) -> tuple[str, str]:
    """The cheapest candidate within :data:`TIE` of the best mean accuracy (candidates are
    listed cheapest first), and why."""
    acc = scored(results)
    if not acc:
        name = "linear" if "linear" in results else next(iter(results))
        return name, f"{name}: too few training recordings per class to cross-validate"
    best = max(acc.values())
    tied = [c.name for c in cands if c.name in acc and acc[c.name] >= best - TIE]
    name = tied[0]
    why = (f"{name}: mean accuracy over the decision times {100 * acc[name]:.2f} "
           f"% (best {100 * best:.2f} %; candidates within {100 * TIE:g} points of "
           f"the best are tied and the cheapest of them wins)")
    stopped = [k for k, v in results.items() if v.get("stopped")]
    if stopped:
        why += (f"; stopped early, as they could no longer change the choice: "
                f"{', '.join(stopped)}")
    return name, why


def must_exceed(results: dict[str, dict], cands: Sequence[Candidate]
                ) -> tuple[str, float] | None:
    """The candidate chosen among those cross-validated so far and the mean accuracy a
    costlier candidate must exceed to change that choice (its accuracy plus :data:`TIE`);
    None before any."""
    if not scored(results):
        return None
    name, _ = choose(results, cands)
    return name, results[name]["mean_accuracy"] + TIE


def could_change(results: dict[str, dict], cands: Sequence[Candidate], name: str) -> bool:
    """Whether the stopped candidate ``name``, at any mean accuracy up to its bound
    (``results[name]["mean_accuracy_at_most"]``), could change the choice among the
    candidates cross-validated on every fold: it could not when it never reaches the tie
    of their best, or when it is costlier than their choice and cannot exceed it by more
    than the tie (then the choice stays within the tie of the best and is cheaper)."""
    acc = scored(results)
    if not acc:
        return True
    bound = results[name]["mean_accuracy_at_most"]
    if bound < max(acc.values()) - TIE:
        return False
    chosen, _ = choose(results, cands)
    order = [c.name for c in cands]
    return not (order.index(name) > order.index(chosen) and bound <= acc[chosen] + TIE)
