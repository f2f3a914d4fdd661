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
