"""The material trainer's trial of the mains notch: tried when recordings carry steady
mains lines, kept when the cross-validation says it costs nothing, refused when the hum is
what tells the classes apart, kept without a trial when no recording has lines (it changes
nothing then), and never tried when the user decided."""
from __future__ import annotations

import numpy as np
import pytest
import soundfile as sf
from scipy.signal import butter, sosfilt

from fingertip.models.vibration.augment import NONE
from fingertip.models.vibration.classify import VibrationClassifier, load_folder
from fingertip.models.vibration.mains_trial import recordings_with_lines
from fingertip.models.vibration.candidates import TIE
from fingertip.models.vibration.material import train_material

RATE = 8000
N = 8


def _noise(rng: np.random.Generator, band: tuple[float, float]) -> np.ndarray:
    sos = butter(4, [band[0] / (RATE / 2), band[1] / (RATE / 2)], "bandpass", output="sos")
    x = sosfilt(sos, rng.standard_normal(RATE))
    return 0.05 * x / np.std(x)


def _hum(rng: np.random.Generator, level: float) -> np.ndarray:
    t = np.arange(RATE) / RATE
    f = 50.0 * (1 + 0.002 * rng.uniform(-1, 1))
    return level * sum(a * np.sin(2 * np.pi * k * f * t + rng.uniform(0, 6.3))
                       for k, a in ((1, 1.0), (3, 0.5), (5, 0.3)))


def _write(root, classes: dict[str, tuple[tuple[float, float], str]], seed: int = 0):
    """``classes``: name -> (noise band, hum: 'none', 'all' or 'half' of the recordings)."""
    for ci, (name, (band, hum)) in enumerate(classes.items()):
        (root / name).mkdir(parents=True)
        for k in range(N):
            rng = np.random.default_rng([seed, ci, k])
            x = _noise(rng, band)
            if hum == "all" or (hum == "half" and k % 2):
                x = x + _hum(rng, 0.1)
            sf.write(root / name / f"{k}.wav", x, RATE, subtype="FLOAT")
    return root


def _train(folder, out, **kw):
    return train_material(folder, out, folds=4, models=("linear",), augment=NONE,
                          plot=False, **kw)


def test_hum_that_says_nothing_about_the_class_is_notched(tmp_path):
    """Two textures told apart by their bands; half of each class's recordings hum. The
    notch costs nothing, so it is kept, and the exported model notches at run time."""
    data = _write(tmp_path / "d", {"low": ((200, 800), "half"),
                                   "high": ((1000, 3000), "half")})
    assert len(recordings_with_lines(load_folder(data))) == N
    r = _train(data, tmp_path / "m")
    notch = r.report["mains_notch"]
    assert notch["recordings_with_lines"] == N
    assert notch["adopted"]
    assert notch["mean_accuracy_with"] >= notch["mean_accuracy_without"] - TIE
    assert r.report["candidates"]["linear"]["mains_notch"] is True
    assert VibrationClassifier(r.model_path).cfg.mains_notch


def test_hum_that_is_the_cue_is_kept(tmp_path):
    """The same texture in both classes, one of them humming: the hum is all that tells
    them apart, so notching it would cost everything, and the trial refuses it."""
    data = _write(tmp_path / "d", {"humming": ((60, 3900), "all"),
                                   "quiet": ((60, 3900), "none")})
    r = _train(data, tmp_path / "m")
    notch = r.report["mains_notch"]
    assert not notch["adopted"], notch
    assert "not adopted" in notch["why"]
    assert r.report["accuracy_by_time"]["whole"]["accuracy"] == pytest.approx(1.0)
    assert not VibrationClassifier(r.model_path).cfg.mains_notch


def test_without_lines_the_notch_is_kept_for_free_and_the_users_word_wins(tmp_path):
    """No recording carries lines: the notch changes none of them, so the model and its
    answers are those without it; it is kept (it acts only on hum that comes later)."""
    data = _write(tmp_path / "d", {"low": ((200, 800), "none"),
                                   "high": ((1000, 3000), "none")})
    r = _train(data, tmp_path / "m")
    notch = r.report["mains_notch"]
    assert notch["recordings_with_lines"] == 0 and notch["adopted"]
    assert "changes none of them" in notch["why"]
    assert VibrationClassifier(r.model_path).cfg.mains_notch
    off = _train(data, tmp_path / "off", mains_notch=False)
    assert off.report["mains_notch"]["why"] == "off: asked (not tried)"
    assert not VibrationClassifier(off.model_path).cfg.mains_notch
    assert off.report["accuracy_by_time"] == r.report["accuracy_by_time"]
    assert off.report["summary"]["temperature"] == r.report["summary"]["temperature"]
    hum = _write(tmp_path / "h", {"humming": ((60, 3900), "all"),
                                  "quiet": ((60, 3900), "none")})
    forced = _train(hum, tmp_path / "on", mains_notch=True)
    assert forced.report["mains_notch"]["why"] == "on: asked (not tried)"
    assert VibrationClassifier(forced.model_path).cfg.mains_notch


@pytest.mark.parametrize("margin, adopted", [(+0.001, True), (-0.001, False)])
def test_a_notch_that_costs_less_than_the_tie_is_kept(tmp_path, monkeypatch, margin, adopted):
    """The rule is the augmentation's: the notch is kept unless the cross-validation puts
    it more than TIE below the plain model. The trial is asked for that very bound, and
    an accuracy just above or below it decides."""
    from fingertip.models.vibration import mains_trial
    from fingertip.models.vibration.cross_validation import Trial

    seen = []

    def trial(cand, cw, labels, folds, classes, seed, clean, need, **_):
        seen.append(need)
        acc = need + margin
        table = {"whole": {"seconds": None, "accuracy": acc, "recordings": len(labels)}}
        return Trial(clean, len(folds), table, None)

    monkeypatch.setattr(mains_trial, "cross_validate_against", trial)
    data = _write(tmp_path / "d", {"low": ((200, 800), "half"),
                                   "high": ((1000, 3000), "half")})
    notch = _train(data, tmp_path / "m").report["mains_notch"]
    assert seen and seen[0] == pytest.approx(notch["mean_accuracy_without"] - TIE)
    assert notch["adopted"] is adopted
    assert notch["mean_accuracy_with"] == pytest.approx(seen[0] + margin)
    assert f"{100 * TIE:g} points" in notch["rule"]


def test_each_training_recording_is_searched_for_lines_once(tmp_path, monkeypatch):
    """The trial's count of the recordings with lines and its notched features share one
    search per recording (the public search function, counted by the samples it sees)."""
    from fingertip.models.vibration import mains

    data = _write(tmp_path / "d", {"low": ((200, 800), "half"),
                                   "high": ((1000, 3000), "half")})
    ds = load_folder(data)
    mine = {np.asarray(it.rec.samples).tobytes(): 0 for it in ds.items}
    real = mains.find_mains_lines

    def counted(x, rate):
        key = np.asarray(x).tobytes()
        if key in mine:
            mine[key] += 1
        return real(x, rate)

    monkeypatch.setattr(mains, "find_mains_lines", counted)
    r = _train(data, tmp_path / "m", jobs=1)
    assert r.report["mains_notch"]["recordings_with_lines"] == N
    assert "mean_accuracy_with" in r.report["mains_notch"]      # the trial ran its folds
    assert sorted(set(mine.values())) == [1]


def test_the_notched_features_reuse_the_lines_found_and_the_clean_windows(tmp_path):
    """The notched bank built from the lines found once, with the clean windows for the
    recordings without lines, equals the one that searches every recording itself."""
    from dataclasses import replace

    from fingertip.models.vibration.bank import build_bank
    from fingertip.models.vibration.candidates import candidates
    from fingertip.models.vibration.mains_trial import mains_lines_of
    from fingertip.models.vibration.setup import choose_setup

    data = _write(tmp_path / "d", {"low": ((200, 800), "half"),
                                   "high": ((1000, 3000), "half")})
    ds = load_folder(data)
    setup = choose_setup(ds)
    notched = replace(setup, cfg=replace(setup.cfg, mains_notch=True))
    cands = candidates(setup, ("linear", "cnn"))
    clean = build_bank(setup, ds, cands, "clean")
    lines = mains_lines_of(ds)
    assert sum(bool(v) for v in lines) == N
    ticks = []
    shared = build_bank(notched, ds, cands, "n", lambda: ticks.append(1), lines=lines,
                        clean=clean)
    alone = build_bank(notched, ds, cands, "n")
    assert len(ticks) == N                                      # only those with lines
    for a, b in ((shared.train, alone.train), (shared.test, alone.test),
                 (shared.own["cnn"].train, alone.own["cnn"].train),
                 (shared.own["cnn"].test, alone.own["cnn"].test)):
        for x, y in zip(a, b, strict=True):
            np.testing.assert_array_equal(x.inputs, y.inputs)
            np.testing.assert_array_equal(x.level_db, y.level_db)
    for i, found in enumerate(lines):
        if not found:
            assert shared.train[i] is clean.train[i]
        else:
            assert not np.array_equal(shared.test[i].inputs, clean.test[i].inputs)
