"""Band power spectrograms: a recording's samples to (frames, bands) power spectral densities.

The STFT gathers every frame at once (strided view + one fancy index, no Python loop per
frame), windows it in place and calls ``scipy.fft.rfft`` on the whole block in float32
(``dtype=np.float64`` gives the reference); buffers are reused between calls of the same
size. :class:`Spectrogrammer` keeps one :class:`Stft` per working rate and applies the
configuration's mains notch and resampling first (:mod:`.features` holds the configuration,
the bands and the rate; :mod:`.window_features` turns the spectrogram into a model's
inputs). Imports numpy and scipy only.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import scipy.fft
from scipy.signal.windows import hann

from .features import FeatureConfig, FeatureError, check_finite, to_working_rate
from .mains import notch_lines, remove_mains


class Stft:
    """Band power spectrogram at one working rate: frames every ``hop_s``, ``win_s`` long.

    Frame ``k`` starts at sample ``round(k * hop_s * rate)`` (exact times at every rate).
    """

    def __init__(self, rate: float, cfg: FeatureConfig, dtype: type = np.float32) -> None:
        if cfg.f_hi is None:
            raise FeatureError("FeatureConfig.f_hi must be decided before an Stft is built")
        self.rate = float(rate)
        self.cfg = cfg
        self.dtype = np.dtype(dtype)
        self.win = max(8, int(round(cfg.win_s * rate)))
        self.n_fft = scipy.fft.next_fast_len(self.win, real=True)
        self.hop = cfg.hop_s * rate
        w = hann(self.win, sym=False)
        self.window = w.astype(self.dtype)
        self.freqs = np.fft.rfftfreq(self.n_fft, 1 / rate)
        # Power spectral density (units^2/Hz, one-sided) per bin, then weighted per band.
        psd_scale = 2.0 / (rate * float(np.sum(w * w)))
        self.weights = (cfg.band_weights(self.freqs) * psd_scale).astype(
            self.dtype)
        self._starts = np.zeros(0, dtype=np.intp)
        self._frames = np.zeros((0, self.n_fft), dtype=self.dtype)
        self._power = np.zeros((0, len(self.freqs)), dtype=self.dtype)
        self._tmp = np.zeros((0, len(self.freqs)), dtype=self.dtype)
        self.dc_bins = bool(np.any(self.weights[:2] != 0))
        """Whether a band reaches FFT bins 0 and 1 (then each frame's mean is removed)."""

    def n_frames(self, n_samples: int) -> int:
        if n_samples < self.win:
            return 0
        k = int((n_samples - self.win) / self.hop) + 1
        while k > 0 and int(round((k - 1) * self.hop)) + self.win > n_samples:
            k -= 1
        return k

    def frame_starts(self, k: int) -> np.ndarray:
        if len(self._starts) < k:
            self._starts = np.rint(np.arange(max(k, 2 * len(self._starts))) * self.hop
                                   ).astype(np.intp)
        return self._starts[:k]

    def _buffers(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        if len(self._frames) < k:  # grow only: repeated calls reuse the same memory
            self._frames = np.zeros((k, self.n_fft), dtype=self.dtype)  # zero-padded tail
            self._power = np.empty((k, len(self.freqs)), dtype=self.dtype)
            self._tmp = np.empty((k, len(self.freqs)), dtype=self.dtype)
        return self._frames[:k], self._power[:k]

    def band_power(self, x: np.ndarray) -> np.ndarray:
        """(frames, bands) band PSD of ``x`` (at this rate).

        The input's mean is removed (in float64 when the input is float64, before any cast:
        an ADC's offset must not eat float32's precision) and it is scaled by its own peak
        (so float32 neither overflows nor underflows): the result is relative to that peak,
        which the per-window normalisation cancels. Each frame's own mean only leaks into
        FFT bins 0 and 1 with a periodic Hann window, which no band reaches unless f_lo is
        set below about two bins (then frames are centred too).
        """
        x = np.asarray(x)
        k = self.n_frames(len(x))
        nb = self.weights.shape[1]
        if k == 0:
            return np.zeros((0, nb), dtype=self.dtype)
        work = x - x.mean(dtype=np.float64).astype(x.dtype)
        peak = float(np.max(np.abs(work)))
        if peak > 0:
            work *= work.dtype.type(1.0 / peak) if np.isfinite(1.0 / peak) else 1.0
        xs = work.astype(self.dtype, copy=False)
        padded, power = self._buffers(k)
        frames = padded[:, :self.win]
        view = np.lib.stride_tricks.sliding_window_view(xs, self.win)
        frames[...] = view[self.frame_starts(k)]  # one gather (np.take would copy the view)
        if self.dc_bins:
            frames -= frames.mean(axis=1, keepdims=True)
        frames *= self.window
        spec = scipy.fft.rfft(padded, axis=1, workers=1)
        np.multiply(spec.real, spec.real, out=power)
        tmp = self._tmp[:k]
        np.multiply(spec.imag, spec.imag, out=tmp)
        power += tmp
        return power @ self.weights

    def frame_times(self, k: int) -> np.ndarray:
        """Start time (s) of each of ``k`` frames."""
        return self.frame_starts(k) / self.rate


class Spectrogrammer:
    """Recording -> band power spectrogram, with one cached :class:`Stft` per working rate."""

    def __init__(self, cfg: FeatureConfig, dtype: type = np.float32) -> None:
        self.cfg = cfg
        self.dtype = dtype
        self._stft: dict[float, Stft] = {}

    def stft(self, rate: float) -> Stft:
        st = self._stft.get(rate)
        if st is None:
            st = self._stft[rate] = Stft(rate, self.cfg, self.dtype)
        return st

    def __call__(self, x: np.ndarray, rate: float, what: str = "the recording",
                 lines: Sequence[float] | None = None) -> np.ndarray:
        """(frames, bands) band power of samples ``x`` at ``rate``. ``lines``: the mains
        lines of ``x`` (:func:`~.mains.find_mains_lines`) when found already (a trainer
        searches each recording once); None: searched here when the features notch."""
        self.cfg.check_supports(rate, what)
        x = np.asarray(x)
        if x.ndim != 1:
            raise FeatureError(f"{what}: samples must be 1-D, not {x.shape}")
        check_finite(x, what, rate)
        if self.cfg.mains_notch:  # at the recording's own rate: finest lines, fewest samples
            x = remove_mains(x, rate) if lines is None else notch_lines(x, rate, list(lines))
        y, r = to_working_rate(x, rate, self.cfg.canonical_rate)
        return self.stft(r).band_power(y)


def band_power(x: np.ndarray, rate: float, cfg: FeatureConfig | None = None,
               dtype: type = np.float32) -> np.ndarray:
    """(frames, bands) band PSD of ``x`` at ``rate`` (one-off; classifiers keep a
    :class:`Spectrogrammer`)."""
    cfg = (cfg or FeatureConfig()).resolved(rate)
    return Spectrogrammer(cfg, dtype)(x, rate)
