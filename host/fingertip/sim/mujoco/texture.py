"""Sliding excitation streamed block by block: the same texture model as the virtual
fingertip's ``slide_excitation`` (micro-roughness, macro period with clicks, stick-slip),
driven by a slip speed and a normal force that change every physics step.

Everything is a function of the sliding distance ``x`` (the integral of the slip speed), not
of time or of the physics step: the micro-roughness is one seeded periodic profile on a fixed
spatial grid (a fraction of the material's wavelength), the clicks fall where ``x`` crosses a
period, the stick-slip events where it crosses positions drawn ahead from the material's slip
distance. The same motion therefore gives the same excitation whatever the step, and the
excitation continues seamlessly across blocks (kernels that run past a block's end are carried
over).
"""
from __future__ import annotations

import math

import numpy as np

from .project import REF_NORMAL_N, REF_SPEED_MM_S, Material, half_sine, place

PROFILE_POINTS = 1 << 17
"""Points of the periodic micro-roughness profile (8 per wavelength: 0.1-0.7 m of surface)."""
POINTS_PER_WAVELENGTH = 8
STICK_SLIP_TAU_S = 1.2e-3


def periodic_profile(mat: Material, rng: np.random.Generator) -> tuple[np.ndarray, float]:
    """Unit-rms periodic micro-roughness of ``mat`` and its grid step (mm): the spectrum of
    ``vibration.roughness_profile`` (log-Gaussian around the wavelength plus a tail)."""
    dx = mat.wavelength_um * 1e-3 / POINTS_PER_WAVELENGTH
    n = PROFILE_POINTS
    spec = np.fft.rfft(rng.standard_normal(n))
    k = np.fft.rfftfreq(n, dx)
    kc = 1e3 / mat.wavelength_um
    with np.errstate(divide="ignore"):
        octaves = np.log2(np.maximum(k, 1e-12) / kc)
    spec *= np.sqrt(np.exp(-0.5 * (octaves / mat.bandwidth_oct) ** 2)
                    + mat.tail / (1 + (k / kc) ** 2))
    spec[0] = 0
    z = np.fft.irfft(spec, n)
    return z / (z.std() or 1.0), dx


class TextureStream:
    """The dynamic nail force of sliding over one material, one block at a time."""

    def __init__(self, mat: Material, fs: int, rng: np.random.Generator) -> None:
        self.mat, self.fs, self.rng = mat, fs, rng
        self.profile, self.dx = periodic_profile(mat, rng)
        self.amp = math.exp(0.15 * rng.standard_normal())
        self.phase = float(rng.uniform())
        self.x = 0.0
        self.next_slip = self._slip_gap(REF_NORMAL_N)
        kernels = [np.zeros(1)]
        if mat.period_mm and mat.click_n:
            kernels.append(half_sine(mat.click_ms * 1e-3, fs))
        if mat.stick_slip_n:
            tau = STICK_SLIP_TAU_S * fs
            kernels.append(np.exp(-np.arange(int(6 * tau)) / tau))
        self._click = kernels[1] if mat.period_mm and mat.click_n else None
        self._slip = kernels[-1] if mat.stick_slip_n else None
        self.carry = np.zeros(max(len(k) for k in kernels))

    def _slip_gap(self, normal_n: float) -> float:
        return self.mat.slip_mm * max(normal_n, 0.05) / REF_NORMAL_N \
            * float(self.rng.gamma(8.0, 1 / 8.0))

    def block(self, speed_mm_s: np.ndarray, normal_n: np.ndarray) -> np.ndarray:
        """Excitation (N) for one block, given the slip speed and the normal force at each of
        its samples; the sliding distance carries on from the previous block."""
        mat, fs, n = self.mat, self.fs, len(speed_mm_s)
        out = np.zeros(n + len(self.carry))
        out[:len(self.carry)] += self.carry
        x = self.x + np.cumsum(speed_mm_s) / fs
        x_prev = self.x
        self.x = float(x[-1]) if n else self.x
        if n == 0 or self.x <= x_prev:
            self.carry = out[n:].copy()
            return out[:n]
        scale = np.sqrt(speed_mm_s / REF_SPEED_MM_S) \
            * (np.maximum(normal_n, 0.0) / REF_NORMAL_N) ** 0.7
        pos = x / self.dx
        i = np.floor(pos).astype(np.int64)
        frac = pos - i
        i %= len(self.profile)
        j = (i + 1) % len(self.profile)
        f = self.profile[i] * (1 - frac) + self.profile[j] * frac
        if mat.period_mm:
            env = np.sin(np.pi * (x / mat.period_mm + self.phase)) ** 2
            f *= 1 + mat.depth * (2 * env - 1)
        f *= mat.roughness_n * self.amp * scale
        out[:n] += f
        t = np.arange(n) / fs
        if self._click is not None:
            first = math.ceil(x_prev / mat.period_mm + self.phase)
            last = math.floor(self.x / mat.period_mm + self.phase)
            if last >= first:
                at = (np.arange(first, last + 1) - self.phase) * mat.period_mm
                when = np.interp(at, x, t)
                k = np.searchsorted(x, at).clip(0, n - 1)
                amp = mat.click_n * self.amp * scale[k] \
                    * np.exp(0.3 * self.rng.standard_normal(len(at)))
                out += place(len(out), when, amp, self._click, fs)
        if self._slip is not None:
            at: list[float] = []
            while self.next_slip <= self.x:
                at.append(self.next_slip)
                k = min(int(np.searchsorted(x, self.next_slip)), n - 1)
                self.next_slip += self._slip_gap(float(normal_n[k]))
            if at:
                a = np.asarray(at)
                k = np.searchsorted(x, a).clip(0, n - 1)
                amp = -mat.stick_slip_n * normal_n[k] * self.amp \
                    * np.exp(0.25 * self.rng.standard_normal(len(a)))
                out += place(len(out), np.interp(a, x, t), amp, self._slip, fs)
        self.carry = out[n:].copy()
        return out[:n]
