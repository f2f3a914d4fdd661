"""Training-time augmentation: what changes from one day of recording to the next.

A material model trained on one session must survive the next: another sliding speed,
mains hum picked up by the piezo lead, the hand's own motors. None of these is about the
material, so the trainer shows the model each training recording again under a random
draw of them (:func:`augmented`), and the model learns to look past them. The
disturbances here are generic signal models chosen for real sensors, *not* the
simulator's (:mod:`fingertip.sim.physics.disturbances` is never imported: a model tuned to
the simulator's own hum and motors would say nothing about other people's recordings):

- **speed**: a slide ``s`` times faster shifts a texture's spectrum up by ``s`` (spatial
  wavelength / speed); the recording is resampled so that its frequencies scale by a
  log-uniform factor (0.67-1.5 by default) at the same rate (it becomes shorter or longer;
  longer copies are cut to the original length);
- **hum**: 50 or 60 Hz (either grid, 0.3 % off nominal) with random harmonics up to the
  ninth, odd ones stronger, a slow amplitude wander, at a random level relative to the
  recording (-20 to +10 dB by default);
- **motor**: a tonal series at a random fundamental (30-800 Hz) with 1/k harmonics and a
  few percent of frequency wander, plus broadband noise in a random octave band, at -20 to
  +5 dB relative to the recording.

Input gain needs no augmentation: every feature window is normalised by its own power.
Numpy and scipy only.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace
from fractions import Fraction

import numpy as np
from scipy.signal import butter, resample_poly, sosfilt

from .features import CANONICAL_RATE, Recording, to_working_rate

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class AugmentConfig:
    """How many augmented copies of each training recording, and the ranges drawn from."""

    copies: int = 1
    """Copies per training recording (0: no augmentation). One by default: every training
    run cross-validates its chosen candidate again with them, within the trainer's time
    budget."""
    p_speed: float = 0.5
    p_hum: float = 0.5
    p_motor: float = 0.5
    speed: tuple[float, float] = (0.67, 1.5)
    """Frequency scale factors (log-uniform)."""
    hum_db: tuple[float, float] = (-20.0, 10.0)
    """Hum power relative to the recording's power, dB (uniform)."""
    motor_db: tuple[float, float] = (-20.0, 5.0)
    motor_hz: tuple[float, float] = (30.0, 800.0)
    """Fundamental of the motor's tonal series (log-uniform, capped below Nyquist)."""

    def __post_init__(self) -> None:
        if self.copies < 0:
            raise ValueError(f"copies must be >= 0, not {self.copies}")
        for name in ("p_speed", "p_hum", "p_motor"):
            if not 0 <= getattr(self, name) <= 1:
                raise ValueError(f"{name} must be a probability in [0, 1]")
        if not 0 < self.speed[0] <= self.speed[1]:
            raise ValueError(f"speed factors must be 0 < low <= high, not {self.speed}")
        if not 0 < self.motor_hz[0] <= self.motor_hz[1]:
            raise ValueError(f"motor_hz must be 0 < low <= high, not {self.motor_hz}")

    def speed_only(self) -> AugmentConfig:
        """The same copies with the change of speed alone (always drawn), no hum or motor:
        the part of the draw that costs a linear model least (docs/classifiers.md)."""
        return replace(self, p_speed=1.0, p_hum=0.0, p_motor=0.0)

    @classmethod
    def from_dict(cls, d: dict) -> AugmentConfig:
        """The inverse of :meth:`to_dict` (as stored in a training report)."""
        return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in d.items()})

    def to_dict(self) -> dict:
        return {"copies": self.copies, "p_speed": self.p_speed, "p_hum": self.p_hum,
                "p_motor": self.p_motor, "speed": list(self.speed),
                "hum_db": list(self.hum_db), "motor_db": list(self.motor_db),
                "motor_hz": list(self.motor_hz)}


NONE = AugmentConfig(copies=0)


def _power(x: np.ndarray) -> float:
    return float(np.mean((x - x.mean()) ** 2))


def _wander(n: int, rate: float, rng: np.random.Generator, hz: float) -> np.ndarray:
    """Smooth zero-mean noise of unit rms, band-limited to about ``hz`` (linear
    interpolation of random knots: cheap, and smooth enough for a slow modulation)."""
    knots = max(2, int(n / rate * hz) + 2)
    v = rng.standard_normal(knots)
    out = np.interp(np.linspace(0, knots - 1, n), np.arange(knots), v)
    sd = out.std()
    return (out - out.mean()) / sd if sd > 0 else out * 0


def scale_frequencies(x: np.ndarray, factor: float, max_den: int = 40) -> np.ndarray:
    """``x`` resampled so that, played at the same rate, its frequencies are ``factor``
    times higher (and it lasts 1 / ``factor`` as long). The factor is approximated by a
    fraction with a denominator of at most ``max_den`` (within 1-2 %)."""
    if not factor > 0:
        raise ValueError(f"factor must be > 0, not {factor}")
    fr = Fraction(factor).limit_denominator(max_den)
    up, down = fr.denominator, fr.numerator  # n_out = n * up / down = n / factor
    if up == down:
        return x.copy()
    return resample_poly(x, up, down)


def hum(n: int, rate: float, rng: np.random.Generator) -> np.ndarray:
    """Unit-rms mains hum: 50 or 60 Hz and random harmonics below 0.45 x the rate."""
    f1 = (50.0 if rng.random() < 0.5 else 60.0) * (1 + 0.003 * rng.uniform(-1, 1))
    t = np.arange(n) / rate
    out = np.zeros(n)
    for k in range(1, 10):
        if k * f1 >= 0.45 * rate:
            break
        # odd harmonics (rectifiers, transformer saturation) are usually the strong ones
        amp = 1.0 if k == 1 else rng.uniform(0.0, 0.6 if k % 2 else 0.2)
        out += amp * np.sin(2 * math.pi * k * f1 * t + rng.uniform(0, 2 * math.pi))
    out *= 1 + 0.1 * _wander(n, rate, rng, 0.5)
    sd = out.std()
    return out / sd if sd > 0 else out


def motor(n: int, rate: float, rng: np.random.Generator,
          f_range: tuple[float, float] = (30.0, 800.0)) -> np.ndarray:
    """Unit-rms motor noise: a wandering tonal series plus broadband noise in a random
    octave band."""
    nyq = 0.45 * rate
    lo, hi = f_range[0], min(f_range[1], nyq / 2)
    f0 = float(np.exp(rng.uniform(math.log(lo), math.log(max(lo, hi)))))
    inst = f0 * (1 + 0.03 * _wander(n, rate, rng, 2.0))
    phase = 2 * math.pi * np.cumsum(inst) / rate
    tones = np.zeros(n)
    for k in range(1, 13):
        if k * f0 >= nyq:
            break
        tones += np.sin(k * phase + rng.uniform(0, 2 * math.pi)) / k
    c_lo = float(np.exp(rng.uniform(math.log(100.0), math.log(max(101.0, nyq / 2)))))
    c_hi = min(nyq, 2 * c_lo * rng.uniform(1.0, 4.0))
    sos = butter(2, [c_lo / (rate / 2), c_hi / (rate / 2) * 0.999], btype="bandpass",
                 output="sos")
    broad = sosfilt(sos, rng.standard_normal(n))
    share = rng.uniform(0.2, 0.8)  # how much of the power is tonal
    out = (math.sqrt(share) * tones / max(tones.std(), 1e-12)
           + math.sqrt(1 - share) * broad / max(broad.std(), 1e-12))
    return out / max(out.std(), 1e-12)


def augment_one(rec: Recording, rng: np.random.Generator, cfg: AugmentConfig,
                canonical: int = CANONICAL_RATE) -> Recording:
    """One random draw of the disturbances of ``cfg`` on ``rec`` (at least one of them),
    at the features' working rate (a 44.1 kHz recording is brought to ``canonical`` first,
    as the features would: the same copy at a third of the cost)."""
    x, rate = to_working_rate(np.asarray(rec.samples, np.float64), rec.rate, canonical)
    x = x - x.mean()
    which = rng.random(3) < (cfg.p_speed, cfg.p_hum, cfg.p_motor)
    if not which.any():
        which[rng.integers(3)] = True
    what = []
    if which[0]:
        f = float(np.exp(rng.uniform(math.log(cfg.speed[0]), math.log(cfg.speed[1]))))
        x = scale_frequencies(x, f)[:len(x)]
        what.append(f"speed x{f:.2f}")
    p = _power(x)
    if p > 0:
        if which[1]:
            db = rng.uniform(*cfg.hum_db)
            x = x + hum(len(x), rate, rng) * math.sqrt(p * 10 ** (db / 10))
            what.append(f"hum {db:+.0f} dB")
        if which[2]:
            db = rng.uniform(*cfg.motor_db)
            x = x + motor(len(x), rate, rng, cfg.motor_hz) * math.sqrt(p * 10 ** (db / 10))
            what.append(f"motor {db:+.0f} dB")
    return Recording(x, rate, f"{rec.source} [{', '.join(what)}]", None, 0.0,
                     {"augmented": what})


def augmented(rec: Recording, cfg: AugmentConfig, seed: int | list[int],
              canonical: int = CANONICAL_RATE) -> list[Recording]:
    """``cfg.copies`` augmented copies of ``rec`` (reproducible from ``seed``)."""
    rng = np.random.default_rng(seed)
    return [augment_one(rec, rng, cfg, canonical) for _ in range(cfg.copies)]
