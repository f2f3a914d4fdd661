"""The material trainer's choice of candidate, and the early stop of a costlier candidate
that can no longer change it: the cheapest within the tie of the best wins; a stopped
candidate says so in the report, takes no part in the choice, and is completed when a
later winner means it might have mattered."""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from fingertip.models.vibration.augment import NONE
from fingertip.models.vibration.candidates import TIE
from fingertip.models.vibration.choice import choose, could_change, must_exceed
from fingertip.models.vibration.material import train_material
from tests.models.vibration.band_noise import write_band_noise

ORDER = [SimpleNamespace(name=n) for n in ("a", "x", "y")]
"""Candidates cheapest first (the rule reads their names and order only)."""


def _full(acc: float) -> dict:
    return {"mean_accuracy": acc}


def _stopped(bound: float) -> dict:
    return {"mean_accuracy": math.nan, "mean_accuracy_at_most": bound, "stopped": "..."}


def test_the_cheapest_within_the_tie_of_the_best_wins_and_stopped_ones_take_no_part():
    assert choose({"a": _full(0.90), "x": _full(0.904)}, ORDER)[0] == "a"
    assert choose({"a": _full(0.90), "x": _full(0.906)}, ORDER)[0] == "x"
    name, why = choose({"a": _full(0.90), "x": _stopped(0.99)}, ORDER)
    assert name == "a" and "stopped early" in why and "x" in why
    # a costlier candidate must exceed the one chosen so far by more than the tie
    assert must_exceed({"a": _full(0.898), "x": _full(0.90)}, ORDER) == ("a", 0.898 + TIE)
    assert must_exceed({}, ORDER) is None


def test_a_stopped_candidate_is_completed_only_when_it_could_change_the_choice():
    # costlier than the choice and unable to beat it by more than the tie: never matters
    assert not could_change({"a": _full(0.899), "x": _stopped(0.9035)}, ORDER, "x")
    # never within the tie of the best: never matters, wherever it stands
    assert not could_change({"a": _full(0.892), "x": _stopped(0.8945),
                             "y": _full(0.90)}, ORDER, "x")
    # a costlier winner (y) came after it: at its bound it would tie y and, cheaper, win
    assert could_change({"a": _full(0.892), "x": _stopped(0.8965),
                         "y": _full(0.90)}, ORDER, "x")


@pytest.fixture(scope="module")
def easy(tmp_path_factory):
    """Two classes of noise in bands far apart: the linear candidate gets them all."""
    return write_band_noise(tmp_path_factory.mktemp("easy"),
                            {"low": (200, 600), "high": (1500, 3000)}, per_class=8, seed=3)


def test_costlier_candidates_stop_when_they_cannot_change_the_choice(easy, tmp_path):
    """With the linear candidate right on every recording, no costlier one can exceed it
    by the tie: each stops after its first round of folds, with the certain bound, and the
    report says so; cross-validated on every fold, they choose the same."""
    kw = dict(folds=4, models=("linear", "mlp", "svm"), augment=NONE, mains_notch=False,
              plot=False)
    r = train_material(easy, tmp_path / "m", **kw)
    rep = r.report
    assert rep["model"] == "linear"
    assert rep["candidates"]["linear"]["mean_accuracy"] == pytest.approx(1.0)
    for name in ("mlp", "svm"):
        c = rep["candidates"][name]
        assert c["folds_run"] == 2 and c["bound_certain"]
        assert math.isnan(c["mean_accuracy"]) and c["mean_accuracy_at_most"] <= 1.0
        assert "after 2 of 4 folds" in c["stopped"] and "linear plus the tie" in c["stopped"]
        assert sum(v["recordings"] for v in c["accuracy_by_time"].values()) > 0
        assert c["cost"]["latency_model_ms"]["p50"] > 0 and len(c["fit_s"]) == 2
    assert "stopped early" in rep["choice"]
    every = train_material(easy, tmp_path / "e", every_fold=True, **kw).report
    assert every["model"] == rep["model"]
    assert not any(c.get("stopped") for c in every["candidates"].values())
    for name in ("mlp", "svm"):
        full = every["candidates"][name]["mean_accuracy"]
        assert full <= rep["candidates"][name]["mean_accuracy_at_most"] + 1e-12
        assert len(every["candidates"][name]["fit_s"]) == 4
    assert every["accuracy_by_time"] == rep["accuracy_by_time"]
    np.testing.assert_array_equal(every["summary"]["temperature"],
                                  rep["summary"]["temperature"])
