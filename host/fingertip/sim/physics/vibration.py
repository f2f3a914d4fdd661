"""Contact-microphone physics: dynamic force at the nail -> piezo -> preamp -> sound card.

Scenes describe what happens at the fingernail as a dynamic force f(t) in newtons, sampled at
44.1 kHz (:class:`Excitation`). :class:`AudioChain` turns it into sound-card samples:

    V_in(f)  = S_piezo * H_cap(f) * H_hp(f) * H_aa(f) * H_scene(f) * F(f)    (volts)
    H_cap    = direct + sum_m w_m * w_m^2 / (w_m^2 - w^2 + 2 j zeta_m w_m w)  (cap modes)
    H_hp     = j f / f_c / (1 + j f / f_c),  f_c = 1 / (2 pi R_in C_piezo)    (about 80 Hz)
    H_aa     = 1 / (1 + (j f / f_aa))^2                                       (anti-alias)
    out      = clip(G * (V_in + e_n + hum), +-rail) / V_fs + e_card,  clipped to [-1, 1)
               and quantised to the card's bits; float32, 1.0 = sound-card full scale.

Filtering is one real FFT per excitation segment (no per-sample Python loops); mains hum is
one precomputed mains period tiled by index when it divides the sample rate.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .materials import REF_NORMAL_N, REF_SPEED_MM_S, Material
from ...hardware import FingertipParams, load

Mode = tuple[float, float, float]
"""(frequency Hz, damping ratio, weight)."""


@dataclass
class Excitation:
    """Dynamic force at the nail (N) for samples ``start .. start + len(force)``."""

    force: np.ndarray
    start: int = 0
    lowpass_hz: float | None = None
    modes: tuple[Mode, ...] = ()
    """Extra transmission-path modes (e.g. a box wall between the source and the nail)."""


@dataclass
class AudioResult:
    samples: np.ndarray
    """float32, 1.0 = sound-card full scale."""
    clipped_fraction: float
    preamp_gain: float
    extra: dict = field(default_factory=dict)


def good_fft_size(n: int) -> int:
    """Smallest 2^a 3^b 5^c >= n (fast for pocketfft)."""
    best = 1 << max(0, (n - 1).bit_length())
    p5 = 1
    while p5 < best:
        p35 = p5
        while p35 < best:
            m = p35
            while m < n:
                m *= 2
            best = min(best, m)
            p35 *= 3
        p5 *= 5
    return best


class AudioChain:
    """Piezo, preamp and sound card. ``preamp_gain``, ``hum`` (bool), ``mains_hz`` (50/60)
    and ``noise`` override the parameter file."""

    def __init__(self, params: FingertipParams | None = None, *, preamp_gain: float | None = None,
                 hum: bool = True, mains_hz: float | None = None, noise: bool = True,
                 pad_s: float = 0.05) -> None:
        self.params = p = params or load()
        self.fs = int(p.soundcard.sample_rate_hz)
        self.gain = p.preamp.gain if preamp_gain is None else float(preamp_gain)
        self.hum = hum
        self.mains_hz = p.mains.frequency_hz if mains_hz is None else float(mains_hz)
        self.noise = noise
        self.pad = int(pad_s * self.fs)
        self.hp_hz = 1 / (2 * math.pi * p.preamp.input_resistance_mohm * 1e6
                          * p.piezo.capacitance_nf * 1e-9)
        self._hum_table: np.ndarray | None = None

    # --- linear part ----------------------------------------------------------------------

    def response(self, freqs: np.ndarray, lowpass_hz: float | None = None,
                 modes: Sequence[Mode] = ()) -> np.ndarray:
        """Volts at the preamp input per newton at the nail, complex, at ``freqs`` (Hz)."""
        p = self.params
        cm = p.cap_modes
        w = 2j * math.pi * np.asarray(freqs, dtype=float)
        h = np.full(w.shape, cm.direct, dtype=complex)
        for f0, z, wt in zip(cm.frequency_hz, cm.damping, cm.weight, strict=True):
            w0 = 2 * math.pi * f0
            h += wt * w0 ** 2 / (w0 ** 2 + w ** 2 + 2 * z * w0 * w)
        for f0, z, wt in modes:
            w0 = 2 * math.pi * f0
            h *= 1 + wt * w0 ** 2 / (w0 ** 2 + w ** 2 + 2 * z * w0 * w)
        fc = 2 * math.pi * self.hp_hz
        h *= (w / fc) / (1 + w / fc)
        h /= (1 + w / (2 * math.pi * p.soundcard.antialias_hz)) ** 2
        if lowpass_hz:
            h /= (1 + w / (2 * math.pi * lowpass_hz)) ** 2
        return h * p.piezo.sensitivity_v_per_n

    def filter(self, segments: Sequence[Excitation], n: int) -> np.ndarray:
        """Preamp-input volts (float64, length n) for the excitation segments (their filter
        tails spill into what follows them)."""
        out = np.zeros(n)
        for seg in segments:
            m = len(seg.force)
            if m == 0 or seg.start >= n:
                continue
            nfft = good_fft_size(m + self.pad)
            spec = np.fft.rfft(seg.force, nfft)
            spec *= self.response(np.fft.rfftfreq(nfft, 1 / self.fs), seg.lowpass_hz, seg.modes)
            y = np.fft.irfft(spec, nfft)
            stop = min(n, seg.start + nfft)
            out[seg.start:stop] += y[:stop - seg.start]
        return out

    # --- preamp, hum, noise, clipping, sound card -----------------------------------------

    def hum_wave(self, start: int, n: int) -> np.ndarray:
        """Mains pick-up at the preamp input (volts) for samples start .. start + n."""
        period = self.fs / self.mains_hz
        if abs(period - round(period)) < 1e-9:
            if self._hum_table is None:
                self._hum_table = self._hum_at(np.arange(round(period)))
            idx = (start + np.arange(n)) % round(period)
            return self._hum_table[idx]
        return self._hum_at(start + np.arange(n))

    def _hum_at(self, idx: np.ndarray) -> np.ndarray:
        p = self.params.mains
        t = idx / self.fs
        out = np.zeros(len(idx))
        for k, a in zip(p.harmonics, p.amplitude_uv_rms, strict=True):
            out += a * 1e-6 * math.sqrt(2) * np.sin(2 * math.pi * k * self.mains_hz * t + 0.7 * k)
        return out

    def input_noise_rms(self) -> float:
        """Preamp input noise (volts rms) over the audio band."""
        return self.params.preamp.noise_nv_per_rthz * 1e-9 * math.sqrt(self.fs / 2)

    def noise_floor_rms(self, hum: bool | None = None) -> float:
        """Expected rms of the output with nothing touching (normalised units)."""
        p = self.params
        hum = self.hum if hum is None else hum
        v2 = self.input_noise_rms() ** 2 if self.noise else 0.0
        if hum:
            v2 += sum((a * 1e-6) ** 2 for a in p.mains.amplitude_uv_rms)
        card = 10 ** (p.soundcard.noise_dbfs_rms / 20) if self.noise else 0.0
        return math.sqrt(v2 * self.gain ** 2 / p.soundcard.full_scale_v ** 2 + card ** 2)

    def finish(self, v_in: np.ndarray, start: int, rng: np.random.Generator) -> AudioResult:
        """Preamp input volts -> normalised sound-card samples. ``v_in`` is modified."""
        p = self.params
        n = len(v_in)
        if self.noise:
            v_in += rng.standard_normal(n) * self.input_noise_rms()
        if self.hum:
            v_in += self.hum_wave(start, n)
        v_in *= self.gain
        rail = p.preamp.rail_v
        rail_clipped = int(np.count_nonzero(np.abs(v_in) >= rail))
        np.clip(v_in, -rail, rail, out=v_in)
        v_in *= 1 / p.soundcard.full_scale_v
        if self.noise:
            v_in += rng.standard_normal(n) * 10 ** (p.soundcard.noise_dbfs_rms / 20)
        q = 2.0 ** (p.soundcard.bits - 1)
        top = 1 - 1 / q
        clipped = np.count_nonzero((v_in >= top) | (v_in <= -1.0))
        np.clip(v_in, -1.0, top, out=v_in)
        v_in *= q
        np.rint(v_in, out=v_in)
        v_in *= 1 / q
        # The rail is above the card's full scale, so rail clipping is counted in ``clipped``.
        return AudioResult(v_in.astype(np.float32), clipped / max(n, 1), self.gain,
                           {"rail_clipped": rail_clipped})


def render(scene, n: int, chain: AudioChain, rng: np.random.Generator,
           start: int = 0) -> AudioResult:
    """The scene's audio: ``n`` samples from sample ``start`` (scene time start / fs)."""
    segments = scene.excitation(n, chain.fs)
    return chain.finish(chain.filter(segments, n), start, rng)


# --- synthesis primitives -----------------------------------------------------------------

def half_sine(duration_s: float, fs: int) -> np.ndarray:
    """Impact force pulse of unit peak (Hertz-like contact of the given duration)."""
    m = max(2, int(round(duration_s * fs)))
    return np.sin(np.pi * (np.arange(m) + 0.5) / m)


def damped_sine(freq_hz: np.ndarray, zeta: np.ndarray, fs: int, length: int) -> np.ndarray:
    """Rows of exp(-zeta w t) sin(w t), one per frequency, (M, length)."""
    t = np.arange(length) / fs
    w = 2 * np.pi * np.asarray(freq_hz, float)[:, None]
    return np.exp(-np.asarray(zeta, float)[:, None] * w * t) * np.sin(w * t)


def place(n: int, times_s: np.ndarray, amplitudes: np.ndarray, kernels: np.ndarray,
          fs: int) -> np.ndarray:
    """Sum of kernels (one (L,) shared or (M, L), one per event) placed at ``times_s``."""
    times = np.asarray(times_s, float)
    amps = np.asarray(amplitudes, float)
    if times.size == 0:
        return np.zeros(n)
    k = np.atleast_2d(kernels)
    idx = np.rint(times * fs).astype(np.int64)[:, None] + np.arange(k.shape[1])[None, :]
    w = amps[:, None] * k
    ok = (idx >= 0) & (idx < n)
    return np.bincount(idx[ok], weights=w[ok], minlength=n)[:n]


def smooth_noise(n: int, fs: float, corner_hz: float, rng: np.random.Generator) -> np.ndarray:
    """Unit-variance noise, smooth below ``corner_hz`` (linear interpolation of knots)."""
    knots = max(2, int(math.ceil(n / fs * corner_hz)) + 2)
    values = rng.standard_normal(knots)
    return np.interp(np.arange(n) / fs * corner_hz, np.arange(knots), values)


def roughness_profile(mat: Material, n: int, dx_mm: float, rng: np.random.Generator,
                      wavelength_scale: float = 1.0) -> np.ndarray:
    """Unit-rms spatial micro-roughness, ``n`` points ``dx_mm`` apart."""
    nfft = good_fft_size(n)
    spec = np.fft.rfft(rng.standard_normal(nfft))
    k = np.fft.rfftfreq(nfft, dx_mm)
    kc = 1e3 / (mat.wavelength_um * wavelength_scale)
    with np.errstate(divide="ignore"):
        octaves = np.log2(np.maximum(k, 1e-12) / kc)
    shape = np.exp(-0.5 * (octaves / mat.bandwidth_oct) ** 2) + mat.tail / (1 + (k / kc) ** 2)
    spec *= np.sqrt(shape)
    spec[0] = 0
    z = np.fft.irfft(spec, nfft)[:n]
    return z / (z.std() or 1.0)


def slide_excitation(mat: Material, speed_mm_s: float, normal_n: float, n: int, fs: int,
                     rng: np.random.Generator, *, speed_jitter: float = 0.03,
                     variability: float = 1.0) -> tuple[np.ndarray, dict]:
    """Dynamic nail force (N) for ``n`` samples of sliding, and the positions (mm).

    ``variability`` scales the per-recording scatter of the material (amplitude 15 %,
    wavelength 5 %, damping 10 %): 0 gives the nominal material every time.
    """
    v = speed_mm_s * (1 + speed_jitter * smooth_noise(n, fs, 3.0, rng))
    v = np.maximum(v, 0.05 * speed_mm_s)
    x = np.cumsum(v) / fs
    length = float(x[-1]) + 1.0
    amp_j = math.exp(variability * 0.15 * rng.standard_normal())
    wl_j = math.exp(variability * 0.05 * rng.standard_normal())
    scale = (speed_mm_s / REF_SPEED_MM_S) ** 0.5 * (normal_n / REF_NORMAL_N) ** 0.7
    dx = 0.9 * speed_mm_s / fs
    grid = int(length / dx) + 2
    micro = roughness_profile(mat, grid, dx, rng, wl_j)
    xs = np.arange(grid) * dx
    f = np.interp(x, xs, micro)
    if mat.period_mm:
        phase = rng.uniform() + mat.period_jitter * smooth_noise(
            grid, 1 / dx, 1 / (3 * mat.period_mm), rng)
        env = np.sin(np.pi * (xs / mat.period_mm + phase)) ** 2
        f *= 1 + mat.depth * (2 * np.interp(x, xs, env) - 1)
    f *= mat.roughness_n * amp_j * scale
    if mat.period_mm and mat.click_n:
        count = int(length / mat.period_mm) + 1
        pos = (np.arange(count) + rng.uniform()) * mat.period_mm \
            + mat.period_jitter * mat.period_mm * rng.standard_normal(count)
        pos = pos[(pos > x[0]) & (pos < x[-1])]
        t = np.interp(pos, x, np.arange(n) / fs)
        amp = mat.click_n * amp_j * scale * np.exp(0.3 * rng.standard_normal(len(t)))
        f += place(n, t, amp, half_sine(mat.click_ms * 1e-3, fs), fs)
    if mat.stick_slip_n:
        d = mat.slip_mm * normal_n / REF_NORMAL_N
        count = int(length / d * 1.5) + 2
        pos = np.cumsum(d * rng.gamma(8.0, 1 / 8.0, count))
        pos = pos[pos < x[-1]]
        t = np.interp(pos, x, np.arange(n) / fs)
        amp = -mat.stick_slip_n * normal_n * amp_j * np.exp(0.25 * rng.standard_normal(len(t)))
        tau = 1.2e-3
        kern = np.exp(-np.arange(int(6 * tau * fs)) / (tau * fs))
        f += place(n, t, amp, kern, fs)
    return f, {"position_mm": x, "lowpass_hz": mat.lowpass_hz and mat.lowpass_hz * math.exp(
        variability * 0.1 * rng.standard_normal())}
