"""Vibration features: any rate, any gain, silence, clipping, NaN/Inf, float32 vs float64."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
import soundfile as sf
from scipy.signal import ShortTimeFFT, resample_poly
from scipy.signal.windows import hann

from fingertip.models.vibration.features import (
    CANONICAL_RATE,
    FLOOR_DB,
    N_BANDS,
    FeatureConfig,
    FeatureError,
    as_recording,
    clipped_fraction,
    read_recording,
)
from fingertip.models.vibration.spectrogram import Spectrogrammer, Stft
from fingertip.models.vibration.window_features import (
    gather_windows,
    log_window,
    pooled,
    window_starts,
)

RATES = (2000, 8000, 44100, 48000)


def _noise_with_peaks(rate: float, seconds: float = 1.5, seed: int = 0) -> np.ndarray:
    """Pink-ish noise plus two tones, band-limited below 850 Hz (fits every rate here)."""
    rng = np.random.default_rng(seed)
    n = int(seconds * 48000)
    spec = np.fft.rfft(rng.normal(size=n))
    f = np.fft.rfftfreq(n, 1 / 48000)
    spec *= np.where((f > 60) & (f < 850), 1 / np.sqrt(np.maximum(f, 1)), 0)
    x = np.fft.irfft(spec, n)
    t = np.arange(n) / 48000
    x = x / x.std() + 0.5 * np.sin(2 * np.pi * 300 * t) + 0.3 * np.sin(2 * np.pi * 620 * t)
    return x if rate == 48000 else resample_poly(x, int(rate), 48000) if rate % 1000 == 0 \
        else resample_poly(x, 147, 160)  # 48 kHz -> 44.1 kHz


def _windows(power: np.ndarray, frames: int = 86) -> np.ndarray:
    return log_window(gather_windows(power, window_starts(len(power), frames, 0.1), frames))


@pytest.mark.parametrize("rate", RATES)
def test_every_rate_gives_the_same_shape(rate):
    x = _noise_with_peaks(rate)
    cfg = FeatureConfig().for_rates([rate])        # bands up to 0.45 x rate (<= 7.2 kHz)
    power = Spectrogrammer(cfg)(x, rate)
    assert power.shape[1] == N_BANDS
    assert abs(len(power) - 1.5 / cfg.hop_s) < 5    # same frame rate at every sample rate
    w = _windows(power)
    assert w.shape[1:] == (86, N_BANDS)
    assert pooled(w).shape[1:] == (3 * N_BANDS,)
    assert np.all(np.isfinite(w))
    assert cfg.f_hi == pytest.approx(0.45 * min(rate, CANONICAL_RATE))


def test_same_signal_same_features_at_every_rate():
    """One band-limited signal sampled at 2, 8, 44.1 and 48 kHz: with common bands (up to
    900 Hz), the features agree: the model sees the signal, not the sample rate."""
    cfg = FeatureConfig().for_rates(RATES)
    assert cfg.f_hi == 900
    feats = {r: pooled(_windows(Spectrogrammer(cfg)(_noise_with_peaks(r), r)))
             for r in RATES}
    n = min(len(f) for f in feats.values())
    ref = feats[48000][:n, :N_BANDS]                 # mean dB per band
    for r in RATES:
        assert np.max(np.abs(feats[r][:n, :N_BANDS] - ref)) < 1.5, r


def test_bands_are_power_spectral_density():
    """White noise of variance s2 at rate fs has a one-sided PSD of 2 s2 / fs in every band;
    a tone lands in the band centred nearest to it."""
    fs = 16000
    x = np.random.default_rng(1).normal(0, 0.1, 4 * fs)
    cfg = FeatureConfig().for_rates([fs])
    p = Spectrogrammer(cfg, np.float64)(x, fs)
    # band_power is relative to the recording's (centred) peak: undo that scale here
    psd = p.mean(axis=0) * np.max(np.abs(x - x.mean())) ** 2
    assert np.allclose(psd, 2 * 0.01 / fs, rtol=0.15)
    t = np.arange(fs) / fs
    tone = np.sin(2 * np.pi * 1000 * t) + 1e-3 * np.random.default_rng(2).normal(size=fs)
    band = int(np.argmax(Spectrogrammer(cfg)(tone, fs).mean(axis=0)))
    assert band == int(np.argmin(np.abs(np.log(cfg.band_centres() / 1000))))


def test_stft_matches_scipy_shorttimefft():
    """Same frames, window and power as scipy's ShortTimeFFT (the slow reference)."""
    fs = 16000
    x = np.random.default_rng(3).normal(size=fs) + 3.0      # with a DC offset
    cfg = FeatureConfig().for_rates([fs])
    st = Stft(fs, cfg, np.float64)
    assert st.hop == 186 and st.win == 512 and st.n_fft == 512
    k = st.n_frames(len(x))
    w = hann(512, sym=False)
    frames = np.lib.stride_tricks.sliding_window_view(x, 512)[st.frame_starts(k)]
    raw = np.abs(np.fft.rfft(frames * w, axis=1)) ** 2
    # ShortTimeFFT centres slice p on sample p * hop: shift by half a window; slices 0 and 1
    # would reach before the start (zero-padded there), so compare from slice 2.
    sft = ShortTimeFFT(w, 186, fs, mfft=512)
    ref = (np.abs(sft.stft(x[256:], p0=2, p1=k)) ** 2).T
    assert np.allclose(raw[2:], ref, rtol=1e-9, atol=1e-9 * ref.max())
    # A DC offset (or each frame's mean) only reaches FFT bins 0 and 1 with a periodic Hann
    # window; no band does, so the offset cannot leak into the features.
    assert not st.dc_bins and not st.weights[:2].any()
    centred = frames - frames.mean(axis=1, keepdims=True)
    ours = np.abs(np.fft.rfft(centred * w, axis=1)) ** 2
    assert np.allclose(ours[:, 2:], raw[:, 2:], rtol=1e-9, atol=1e-9 * raw.max())
    # band powers: those spectra through the band matrix, relative to the centred peak
    peak = np.max(np.abs(x - x.mean()))
    bp = st.band_power(x)
    assert np.allclose(bp, (raw / peak ** 2) @ st.weights, rtol=1e-9)
    assert np.allclose(bp, st.band_power(x - 3.0), rtol=1e-9)


def test_gain_and_extreme_values_do_not_matter():
    x = _noise_with_peaks(16000)
    cfg = FeatureConfig().for_rates([16000])
    ref = _windows(Spectrogrammer(cfg, np.float64)(x, 16000))
    for g in (1e-30, 1e-6, 1e6, 1e30):
        for dtype in (np.float32, np.float64):
            if dtype is np.float32 and g > 1e30:
                continue
            w = _windows(Spectrogrammer(cfg, dtype)((x * g).astype(dtype), 16000))
            assert np.all(np.isfinite(w))
            assert np.max(np.abs(w - ref)) < 0.02, (g, dtype)
    assert ref.max() <= 10 * np.log10(86 * N_BANDS) + 1e-9 and ref.min() >= FLOOR_DB
    # an ADC's offset, a million times the signal, costs nothing (removed before float32)
    w = _windows(Spectrogrammer(cfg, np.float32)(1e6 + x, 16000))
    assert np.max(np.abs(w - ref)) < 0.05


def test_float32_against_float64_reference():
    rng = np.random.default_rng(4)
    x = rng.normal(size=88200) * np.exp(rng.normal(size=88200))   # heavy-tailed
    x[1000:1100] *= 1e4                                           # a loud click
    cfg = FeatureConfig().for_rates([44100])
    w32 = _windows(Spectrogrammer(cfg, np.float32)(x.astype(np.float32), 44100))
    w64 = _windows(Spectrogrammer(cfg, np.float64)(x, 44100))
    assert w32.dtype == np.float32 and w64.dtype == np.float64
    assert np.max(np.abs(w32 - w64)) < 0.05                       # dB
    assert np.max(np.abs(pooled(w32) - pooled(w64))) < 0.05


def test_silence_is_finite_and_at_the_floor():
    cfg = FeatureConfig().for_rates([8000])
    sp = Spectrogrammer(cfg)
    w = _windows(sp(np.zeros(16000), 8000))
    assert np.all(w == FLOOR_DB)
    f = pooled(w)
    assert np.all(np.isfinite(f))
    # a window that is silent except for one quiet burst stays finite and bounded
    x = np.zeros(16000)
    x[5000:5100] = 1e-20
    w = _windows(sp(x, 8000))
    assert np.all(np.isfinite(w)) and w.min() >= FLOOR_DB
    # shorter than one frame: no frame, no window, no error
    assert sp(np.zeros(100), 8000).shape == (0, N_BANDS)
    assert _windows(sp(np.zeros(100), 8000)).shape == (0, 86, N_BANDS)


def test_nan_and_inf_are_clear_errors():
    x = np.zeros(8000)
    x[4000] = np.nan
    x[4001] = np.inf
    with pytest.raises(FeatureError, match=r"1 NaN and 1 infinite.*sample 4000 \(0.5000 s\)"):
        as_recording(x, 8000, "rec.wav")
    cfg = FeatureConfig().for_rates([8000])
    with pytest.raises(FeatureError, match="NaN"):
        Spectrogrammer(cfg)(x, 8000)


def test_clipping_is_measured():
    t = np.arange(8000) / 8000
    sine = np.sin(2 * np.pi * 50 * t)
    assert clipped_fraction(sine) < 1e-3
    assert clipped_fraction(np.zeros(100)) == 0.0
    clipped = np.clip(1.5 * sine, -1, 1)
    # |1.5 sin| > c for a share 1 - (2 / pi) asin(c / 1.5) of the time
    assert clipped_fraction(clipped, full_scale=1.0) == pytest.approx(
        1 - 2 / np.pi * np.arcsin(1 / 1.5), abs=0.01)
    assert clipped_fraction(np.clip(1.5 * sine, -0.8, 0.8)) == pytest.approx(  # any level
        1 - 2 / np.pi * np.arcsin(0.8 / 1.5), abs=0.01)
    rec = as_recording((clipped * 32767).astype(np.int16), 8000)
    assert rec.clipped and rec.full_scale == 1.0
    assert not as_recording(sine * 0.5, 8000).clipped


def test_rates_out_of_range_and_models_that_need_more_bandwidth():
    with pytest.raises(FeatureError, match="outside"):
        as_recording(np.zeros(10), 500)
    with pytest.raises(FeatureError, match="outside"):
        as_recording(np.zeros(10), float("nan"))
    cfg = FeatureConfig().for_rates([44100])
    with pytest.raises(FeatureError, match="--max-hz 3600"):
        Spectrogrammer(cfg)(np.zeros(8000), 8000)
    low = FeatureConfig().for_rates([44100], max_hz=3600)
    assert Spectrogrammer(low)(np.ones(8000), 8000).shape[1] == N_BANDS
    with pytest.raises(FeatureError):
        FeatureConfig(n_bands=2)


def test_read_wav_flac_and_csv(tmp_path):
    x = (np.sin(np.arange(4000) / 5) * 0.5).astype(np.float32)
    sf.write(tmp_path / "a.wav", x, 8000, subtype="PCM_16")
    sf.write(tmp_path / "b.flac", np.stack([x, -x], axis=1), 22050, subtype="PCM_24")
    a = read_recording(tmp_path / "a.wav")
    assert a.rate == 8000 and a.full_scale == 1.0 and np.allclose(a.samples, x, atol=1e-4)
    b = read_recording(tmp_path / "b.flac", channel=1)
    assert b.rate == 22050 and np.allclose(b.samples, -x, atol=1e-6)
    with pytest.raises(FeatureError, match="no channel 2"):
        read_recording(tmp_path / "b.flac", channel=2)

    (tmp_path / "c.csv").write_text("# rate=4000\n" + "\n".join(f"{v:.6f}" for v in x))
    c = read_recording(tmp_path / "c.csv")
    assert c.rate == 4000 and len(c.samples) == 4000 and c.full_scale is None
    (tmp_path / "d.csv").write_text("\n".join(f"{v:.6f}" for v in x))
    with pytest.raises(FeatureError, match="no sample rate"):
        read_recording(tmp_path / "d.csv")
    assert read_recording(tmp_path / "d.csv", rate=3000).rate == 3000
    rows = "\n".join(f"{i / 2000:.6f},{v:.6f}" for i, v in enumerate(x))
    (tmp_path / "e.csv").write_text("time_s,piezo_v\n" + rows)
    e = read_recording(tmp_path / "e.csv")
    assert e.rate == pytest.approx(2000) and np.allclose(e.samples, x, atol=1e-6)
    (tmp_path / "f.csv").write_text("# sample_rate: 2500\nvalue\n1\n2\nnan\n")
    with pytest.raises(FeatureError, match="NaN"):
        read_recording(tmp_path / "f.csv")
    (tmp_path / "g.csv").write_text("# fs=2000\n1\nabc\n")
    with pytest.raises(FeatureError, match="not a CSV of numbers"):
        read_recording(tmp_path / "g.csv")
    (tmp_path / "header.csv").write_text("# rate=4000\ntime_s,piezo_v\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's "input contained no data" is not the answer
        with pytest.raises(FeatureError, match="no samples.*time_s"):
            read_recording(tmp_path / "header.csv")
    (tmp_path / "h.wav").write_bytes(b"RIFF nonsense")
    with pytest.raises(FeatureError, match="not a readable"):
        read_recording(tmp_path / "h.wav")
    with pytest.raises(FeatureError, match="no such file"):
        read_recording(tmp_path / "missing.wav")
