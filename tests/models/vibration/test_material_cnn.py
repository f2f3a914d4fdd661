"""The CNN as a material candidate (cross-validated like the others within its budget of
work, skipped by the stated rule beyond it, exported with its temperature when chosen) and the
rule that adopts training-time augmentation only when the cross-validation says it is
free."""
from __future__ import annotations

import numpy as np
import pytest

from fingertip.models.vibration.augment import NONE, AugmentConfig
from fingertip.models.vibration.classify import VibrationClassifier
from fingertip.models.vibration.features import read_recording
from fingertip.models.vibration.material import train_material
from tests.models.vibration.band_noise import write_band_noise

RATE = 8000


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """Two classes of noise in different bands (1 s each, 6 per class), at any gain."""
    return write_band_noise(tmp_path_factory.mktemp("bands"),
                            {"low": (200, 600), "high": (1500, 3000)}, rate=RATE, seed=0)


def cnn_work_of(folder, n_fits: int) -> int:
    """The CNN candidate's projected work on ``folder``, counted here from its windows."""
    from fingertip.models.vibration.bank import candidate_windows
    from fingertip.models.vibration.candidates import CNN_EPOCHS, candidates
    from fingertip.models.vibration.setup import choose_setup
    from fingertip.models.vibration.classify import load_folder

    ds = load_folder(folder)
    cw = candidate_windows(candidates(choose_setup(ds), ("cnn",))[0], ds)
    return sum(len(w) for w in cw.train) * CNN_EPOCHS * n_fits


def test_cnn_is_skipped_beyond_its_budget_with_the_reason(folder, tmp_path):
    need = cnn_work_of(folder, 3)  # 2 folds and the final fit
    assert need > 0
    reports = [train_material(folder, tmp_path / f"m{i}", folds=2, plot=False,
                              models=("linear", "cnn"), cnn_budget=need - 1).report
               for i in range(2)]
    for rep in reports:  # counted, not timed: the same decision and reason every run
        assert set(rep["candidates"]) == {"linear"}
        assert rep["candidates_skipped"]["cnn"] == reports[0]["candidates_skipped"]["cnn"]
    assert (f"projected work {need} window-epochs" in reports[0]["candidates_skipped"]["cnn"]
            and f"exceeds its budget of {need - 1:g}" in reports[0]["candidates_skipped"]["cnn"])
    with pytest.raises(ValueError, match="cnn_budget"):
        train_material(folder, tmp_path / "n", folds=2, cnn_budget=0.0)


def test_cnn_candidate_is_cross_validated_costed_and_exported(folder, tmp_path):
    r = train_material(folder, tmp_path / "m", folds=3, plot=False, models=("cnn",))
    rep = r.report
    assert rep["model"] == "cnn" and not rep["candidates_skipped"]
    c = rep["candidates"]["cnn"]
    assert c["cost"]["parameters"] > 1000 and c["cost"]["latency_model_ms"]["p50"] > 0
    assert rep["accuracy_by_time"]["whole"]["accuracy"] >= 0.9  # two easy classes
    assert rep["onnx_max_abs_diff_vs_float64"] < 1e-4  # temperature inside the graph
    clf = VibrationClassifier(r.model_path)
    res = clf.classify(read_recording(next((folder / "high").glob("*.wav"))))
    assert res.predictions and res.vote == "high"


def test_augmentation_is_adopted_only_when_it_costs_no_accuracy(folder, tmp_path):
    r = train_material(folder, tmp_path / "a", folds=2, plot=False, models=("linear",),
                       augment=AugmentConfig(copies=1))
    aug = r.report["augmentation"]
    assert aug["settings"]["copies"] == 1
    if aug["mean_accuracy_with"] is None:  # stopped early: even a perfect rest loses
        assert not aug["adopted"] and aug["folds_run"] < 2
        assert aug["mean_accuracy_with_at_most"] < aug["mean_accuracy_without"] - 0.005
    else:
        assert aug["adopted"] == (aug["mean_accuracy_with"]
                                  >= aug["mean_accuracy_without"] - 0.005)
    assert ("adopted" if aug["adopted"] else "not adopted") in aug["why"]
    off = train_material(folder, tmp_path / "b", folds=2, plot=False, models=("linear",),
                         augment=NONE).report["augmentation"]
    assert off["adopted"] is False and off["why"] == "no augmentation asked"


def test_best_case_completes_answers_with_right_and_certain_ones():
    from fingertip.models.vibration.scores import Answers, accuracy_by_time, best_case

    labels = np.array([0, 1, 1])
    t = np.array([0.25, 0.5, 1.0])
    wrong = np.tile([0.9, 0.1], (3, 1))
    every = {i: Answers(wrong, wrong, t, 0) for i in range(3)}
    part = {1: every[1]}  # recording 1 answered (wrongly); 0 and 2 still to come
    best = best_case(part, every, labels)
    assert best[1] is every[1] and sorted(best) == [0, 1, 2]
    assert best[2].run[-1].tolist() == [0.0, 1.0] and best[0].run[-1].tolist() == [1.0, 0.0]
    acc = accuracy_by_time(best, labels)["whole"]
    assert acc["recordings"] == 3 and acc["accuracy"] == pytest.approx(2 / 3)


def test_speed_alone_is_tried_when_the_full_draw_is_rejected(folder, tmp_path, monkeypatch):
    import fingertip.models.vibration.augment_trial as augment_trial

    seen = []
    real = augment_trial.trial_one

    def rejecting_full(cand, bank, ds, cfg, *args):
        one, won = real(cand, bank, ds, cfg, *args)
        seen.append(cfg)
        if len(seen) == 1:  # the full draw: rejected whatever it scored
            one = dict(one, adopted=False, why=one["why"].split(":")[0] + ": not adopted")
            won = None
        return one, won

    monkeypatch.setattr(augment_trial, "trial_one", rejecting_full)
    full = AugmentConfig(copies=1)
    aug = train_material(folder, tmp_path / "s", folds=2, plot=False, models=("linear",),
                         augment=full).report["augmentation"]
    assert seen == [full, full.speed_only()]
    assert seen[1].p_speed == 1 and seen[1].p_hum == seen[1].p_motor == 0
    assert [t["what"] for t in aug["tried"]] == ["augmentation", "speed augmentation"]
    assert aug["settings"] == full.speed_only().to_dict()  # what the last trial used
    assert "speed augmentation" in aug["why"]
    seen.clear()  # speed turned off by the caller: no speed trial behind its back
    no_speed = AugmentConfig(copies=1, p_speed=0.0)
    aug = train_material(folder, tmp_path / "n", folds=2, plot=False, models=("linear",),
                         augment=no_speed).report["augmentation"]
    assert seen == [no_speed] and "tried" not in aug


def test_augment_settings_round_trip_through_the_report():
    cfg = AugmentConfig(copies=2, speed=(0.8, 1.25), p_hum=0.1)
    assert AugmentConfig.from_dict(cfg.to_dict()) == cfg
    assert AugmentConfig.from_dict(cfg.speed_only().to_dict()) == cfg.speed_only()
