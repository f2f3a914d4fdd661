"""Stationary mains lines: found from the recording itself, removed before the features,
and a material's own tones on multiples of 50 Hz left alone."""
from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.signal import lfilter

from fingertip.models.vibration.classifier.windows import FeaturePipeline, WindowSpec
from fingertip.models.vibration.features import FeatureConfig, as_recording
from fingertip.models.vibration.mains import find_mains_lines, remove_mains
from fingertip.sim.physics.disturbances import HUM_60, HumParams, mains_hum

RATE = 8000


def texture(seconds: float = 2.0, seed: int = 1) -> np.ndarray:
    """Broadband noise with a low-pass tilt, a stand-in for a slide's texture."""
    rng = np.random.default_rng(seed)
    return lfilter([1.0], [1.0, -0.9], rng.standard_normal(int(seconds * RATE))) * 0.01


def strong_hum(n: int, params: HumParams, level: float, seed: int = 2) -> np.ndarray:
    """The simulator's mains hum (drift, grid offset, odd harmonics) scaled to ``level``
    times the texture's rms."""
    h = mains_hum(n, RATE, np.random.default_rng(seed), params)
    return h / np.std(h) * level


def features(x: np.ndarray, notch: bool) -> np.ndarray:
    cfg = FeatureConfig(mains_notch=notch, f_lo=50.0).for_rates([RATE])
    pipe = FeaturePipeline(cfg, WindowSpec(frames=86, step_s=0.5))
    return pipe.windows(as_recording(x, RATE, "test", 1.0)).inputs


@pytest.mark.parametrize("params", [HumParams(), HUM_60], ids=["50 Hz", "60 Hz"])
def test_strong_hum_gives_nearly_the_features_of_the_clean_recording(params):
    x = texture()
    noisy = x + strong_hum(len(x), params, level=3.0 * np.std(x))
    lines = find_mains_lines(noisy, RATE)
    f0 = params.mains_hz
    assert any(abs(v - f0) < 1.0 for v in lines), lines
    assert any(abs(v - 3 * f0) < 2.0 for v in lines), lines
    clean_f = features(x, notch=True)
    err_on = np.abs(features(noisy, notch=True) - clean_f).mean()
    err_off = np.abs(features(noisy, notch=False) - features(x, notch=False)).mean()
    assert err_on < 0.6, err_on  # dB, mean over every statistic and band
    assert err_on < err_off / 5, (err_on, err_off)


def test_a_material_tone_on_multiples_of_50_hz_is_not_erased():
    """A resonance at 150 Hz with overtones at 300 and 450 Hz: three multiples of 50 Hz,
    narrow and steady, but no 50 Hz fundamental, so it is the material, not the grid."""
    x = texture()
    t = np.arange(len(x)) / RATE
    tone = sum(a * np.sin(2 * np.pi * f * t) for f, a in ((150, 1.0), (300, 0.5),
                                                          (450, 0.3)))
    y = x + tone * 3 * np.std(x)
    assert find_mains_lines(y, RATE) == []
    assert np.array_equal(remove_mains(y, RATE), y)
    np.testing.assert_allclose(features(y, notch=True), features(y, notch=False),
                               atol=1e-6)


def test_the_same_tone_riding_on_hum_keeps_its_content_outside_the_lines():
    """With hum present the 150 Hz family is notched (it is a line of the grid's family),
    but only within a few Hz: a tone at 175 Hz, between harmonics, survives."""
    x = texture()
    t = np.arange(len(x)) / RATE
    y = x + 0.05 * np.sin(2 * np.pi * 175 * t) + strong_hum(len(x), HumParams(), 0.05)
    z = remove_mains(y, RATE)
    f = np.fft.rfftfreq(len(z), 1 / RATE)
    spec_y, spec_z = np.abs(np.fft.rfft(y)), np.abs(np.fft.rfft(z))
    k175 = int(np.argmin(np.abs(f - 175)))
    k50 = int(np.argmin(np.abs(f - 50)))
    assert spec_z[k175] > 0.9 * spec_y[k175]
    assert spec_z[k50] < 0.1 * spec_y[k50]


def test_too_short_a_recording_is_left_alone():
    x = texture(0.05) + strong_hum(400, HumParams(), 0.05)
    assert find_mains_lines(x, RATE) == []


def test_models_saved_before_the_option_load_without_the_notch():
    cfg = FeatureConfig(mains_notch=True).for_rates([RATE])
    d = json.loads(json.dumps(cfg.to_dict()))
    assert FeatureConfig.from_dict(d) == cfg
    del d["mains_notch"]
    assert FeatureConfig.from_dict(d).mains_notch is False


def test_training_and_runtime_pipelines_agree():
    """The runtime rebuilds its pipeline from the model's stored configuration: the same
    windows come out as from the trainer's pipeline."""
    cfg = FeatureConfig(mains_notch=True).for_rates([RATE])
    spec = WindowSpec(frames=43, step_s=0.25)
    x = texture() + strong_hum(2 * RATE, HumParams(), 0.05)
    rec = as_recording(x, RATE, "test", 1.0)
    a = FeaturePipeline(cfg, spec).windows(rec).inputs
    b = FeaturePipeline(FeatureConfig.from_dict(json.loads(json.dumps(cfg.to_dict()))),
                        spec).windows(rec).inputs
    np.testing.assert_array_equal(a, b)


def test_a_struck_tone_that_decays_is_not_taken_for_hum():
    """A kick drum's ring: partials at 50, 100 and 150 Hz decaying over the recording. They
    stand far above their neighbours in the long-term spectrum, but they are not steady,
    so they are content; the same partials held steady are taken for the grid."""
    x = texture(1.0)
    t = np.arange(len(x)) / RATE
    partials = sum(a * np.sin(2 * np.pi * f * t) for f, a in ((50, 1.0), (100, 0.6),
                                                              (150, 0.4)))
    ring = partials * np.exp(-t / 0.15) * 20 * np.std(x)
    assert find_mains_lines(x + ring, RATE) == []
    assert np.array_equal(remove_mains(x + ring, RATE), x + ring)
    held = partials * 3 * np.std(x)
    lines = find_mains_lines(x + held, RATE)
    assert any(abs(v - 50) < 1.0 for v in lines), lines
