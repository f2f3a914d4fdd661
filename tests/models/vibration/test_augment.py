"""Training-time augmentation (fingertip.models.vibration.augment): speed as a frequency
scale, mains hum and motor noise at a level relative to the recording, reproducible draws, and the
trainer's training windows that include them (never the answers it is scored on)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fingertip.models.vibration.augment import (
    NONE,
    AugmentConfig,
    augment_one,
    augmented,
    hum,
    motor,
    scale_frequencies,
)
from fingertip.models.vibration.bank import augmented_copies, candidate_windows
from fingertip.models.vibration.candidates import candidates
from fingertip.models.vibration.setup import choose_setup
from fingertip.models.vibration.classify import Dataset, Labelled
from fingertip.models.vibration.features import as_recording

RATE = 8000.0


def _peak_hz(x: np.ndarray, rate: float = RATE) -> float:
    spec = np.abs(np.fft.rfft(x * np.hanning(len(x))))
    return float(np.fft.rfftfreq(len(x), 1 / rate)[np.argmax(spec)])


def _tone(hz: float, seconds: float = 1.0) -> np.ndarray:
    return np.sin(2 * np.pi * hz * np.arange(int(seconds * RATE)) / RATE)


@pytest.mark.parametrize("factor", [0.5, 0.8, 1.6, 2.5])
def test_speed_scales_every_frequency_and_the_length(factor):
    y = scale_frequencies(_tone(400.0), factor)
    assert len(y) == pytest.approx(RATE / factor, rel=0.03)
    assert _peak_hz(y) == pytest.approx(400.0 * factor, rel=0.03)
    with pytest.raises(ValueError, match="factor"):
        scale_frequencies(_tone(400.0), 0.0)


def test_hum_is_mains_and_its_harmonics_at_unit_level():
    rng = np.random.default_rng(1)
    grids = set()
    for _ in range(12):
        h = hum(int(RATE), RATE, rng)
        assert h.std() == pytest.approx(1.0, rel=1e-6)
        f = _peak_hz(h)
        assert min(abs(f - 50), abs(f - 60)) < 1.5  # the fundamental is the strongest line
        grids.add(50 if abs(f - 50) < 1.5 else 60)
        spec = np.abs(np.fft.rfft(h))
        freqs = np.fft.rfftfreq(len(h), 1 / RATE)
        assert spec[freqs > 0.45 * RATE].max() < 1e-3 * spec.max()  # nothing past 0.45 fs
    assert grids == {50, 60}


def test_motor_noise_has_tones_and_broadband_power_at_unit_level():
    rng = np.random.default_rng(2)
    m = motor(int(RATE), RATE, rng)
    assert m.std() == pytest.approx(1.0, rel=1e-6)
    spec = np.abs(np.fft.rfft(m)) ** 2
    # tones: a few lines hold much more than a flat spectrum would give them
    assert np.sort(spec)[-5:].sum() / spec.sum() > 0.05
    # broadband: more than the lines, spread over many bins
    assert (spec > 1e-3 * spec.max()).sum() > 200


def test_levels_are_relative_to_the_recording_and_draws_reproducible():
    x = 1e-4 * _tone(700.0, 2.0)  # any gain: the levels follow the recording's own power
    cfg = AugmentConfig(copies=3, p_speed=0.0, p_hum=1.0, p_motor=0.0, hum_db=(0.0, 0.0))
    a = augmented(as_recording(x, RATE), cfg, [7, 3])
    b = augmented(as_recording(x, RATE), cfg, [7, 3])
    for r, s in zip(a, b, strict=True):
        np.testing.assert_array_equal(r.samples, s.samples)
        added = r.samples - x
        assert added.std() == pytest.approx(x.std(), rel=0.02)  # 0 dB
        assert "hum +0 dB" in r.source and r.meta["augmented"] == ["hum +0 dB"]
    assert not np.array_equal(a[0].samples, a[1].samples)
    one = augment_one(as_recording(x, RATE), np.random.default_rng(0),
                      AugmentConfig(p_speed=0.0, p_hum=0.0, p_motor=0.0))
    assert one.meta["augmented"]  # at least one disturbance is always applied
    silent = augment_one(as_recording(np.zeros(800), RATE), np.random.default_rng(0),
                         AugmentConfig(p_speed=0.0))
    assert not np.any(silent.samples)  # nothing to scale a level to: left silent
    fast = augment_one(as_recording(np.sin(np.arange(44100) * 0.1), 44100.0),
                       np.random.default_rng(0), AugmentConfig(p_speed=0.0))
    assert fast.rate == 16000 and len(fast.samples) == 16000  # at the features' rate


def test_bad_settings_are_refused():
    with pytest.raises(ValueError, match="copies"):
        AugmentConfig(copies=-1)
    with pytest.raises(ValueError, match="p_hum"):
        AugmentConfig(p_hum=1.5)
    with pytest.raises(ValueError, match="speed"):
        AugmentConfig(speed=(0.0, 2.0))


def test_only_training_windows_are_augmented_and_copies_are_made_once():
    rng = np.random.default_rng(3)
    items = [Labelled(Path(f"{i}.wav"), "ab"[i % 2], i % 2,
                      as_recording(rng.standard_normal(int(RATE)), RATE)) for i in range(4)]
    ds = Dataset(Path("."), ["a", "b"], items)
    cand = candidates(choose_setup(ds), ("linear",))[0]
    plain = candidate_windows(cand, ds, NONE)
    more = candidate_windows(cand, ds, AugmentConfig(copies=2, p_speed=0.0), seed=5)
    for p, m in zip(plain.train, more.train, strict=True):
        assert len(m) == len(p) + 2 * int(p.growing.sum())  # copies: windows from the start
        np.testing.assert_array_equal(m.inputs[:len(p)], p.inputs)
        assert len(m.growing) == len(m.inputs)
    again = candidate_windows(cand, ds, copies=augmented_copies(
        ds, AugmentConfig(copies=2, p_speed=0.0), seed=5))
    for m, a in zip(more.train, again.train, strict=True):
        np.testing.assert_array_equal(m.inputs, a.inputs)
    for p, m in zip(plain.test, more.test, strict=True):
        np.testing.assert_array_equal(m.inputs, p.inputs)
