"""Is a recording worth using? One pure check of an array of samples: silent, constant,
NaN/infinite or clipped.

:func:`signal_problem` says what is wrong in a few words (or None); the trainers refuse a
recording it names, ``record --audio-file`` and ``classify`` warn. :func:`clipped_mask` and
:func:`clipped_fraction` measure clipping (the feature pipeline flags clipped windows with
them too). Pure numpy, no I/O.
"""
from __future__ import annotations

import numpy as np

CLIP_REFUSE = 0.01
"""A recording with more than this share of its samples clipped is refused for training
(a clipped waveform's spectrum is full of harmonics the material did not make)."""


def clipped_mask(x: np.ndarray, full_scale: float | None = None, run: int = 3) -> np.ndarray:
    """Which samples look clipped (bool, one per sample).

    Samples in runs of ``run`` or more consecutive samples sitting at the recording's own
    maximum or minimum (a clipped waveform flattens at its extremes; a sine's peak does not
    repeat), plus, when the ``full_scale`` is known, every sample at it.
    """
    x = np.asarray(x)
    n = len(x)
    out = np.zeros(n, dtype=bool)
    if n == 0:
        return out
    hi, lo = x.max(), x.min()
    if hi == lo:
        return out  # constant (silence): nothing clipped
    at = (x >= hi) | (x <= lo)
    edge = np.diff(np.concatenate(([0], at.view(np.int8), [0])))
    starts, ends = np.flatnonzero(edge == 1), np.flatnonzero(edge == -1)
    long = (ends - starts) >= run
    mark = np.zeros(n + 1, dtype=np.int32)
    np.add.at(mark, starts[long], 1)
    np.add.at(mark, ends[long], -1)
    out = np.cumsum(mark[:n]) > 0
    if full_scale is not None:
        out |= np.abs(x) >= full_scale * (1 - 2 ** -15)
    return out


def clipped_fraction(x: np.ndarray, full_scale: float | None = None, run: int = 3) -> float:
    """Fraction of samples that look clipped (:func:`clipped_mask`)."""
    n = len(x)
    return float(np.count_nonzero(clipped_mask(x, full_scale, run)) / n) if n else 0.0


def signal_problem(x: np.ndarray, full_scale: float | None = None, *,
                   clip_limit: float = CLIP_REFUSE) -> str | None:
    """What makes the samples ``x`` ((n,) or (n, channels)) useless as a recording of
    vibration, in a few words, or None when nothing does: non-finite samples, silence (every
    sample 0), a constant (a DC level, no vibration), or more than ``clip_limit`` of the
    samples clipped (``full_scale``: the known full scale, e.g. 1.0 for WAV/FLAC floats;
    integer arrays use their type's)."""
    a = np.asarray(x)
    if a.size == 0:
        return "empty (no samples)"
    if a.dtype.kind in "iu":
        info = np.iinfo(a.dtype)
        full_scale = float(max(abs(int(info.min)), int(info.max)))
        a = a.astype(np.float64)
    elif a.dtype.kind != "f":
        return f"not numbers ({a.dtype})"
    bad = ~np.isfinite(a)
    if bad.any():
        n_nan = int(np.count_nonzero(np.isnan(a)))
        return (f"{n_nan} NaN and {int(bad.sum()) - n_nan} infinite sample(s), the first at "
                f"sample {int(np.flatnonzero(bad.ravel())[0])}")
    lo, hi = float(a.min()), float(a.max())
    if hi == lo:
        return "silent (every sample is 0)" if hi == 0 else \
            f"constant (every sample is {hi:g}: a DC level, no vibration)"
    cols = a.reshape(len(a), -1) if a.ndim > 1 else a[:, None]
    frac = max(clipped_fraction(cols[:, c], full_scale) for c in range(cols.shape[1]))
    if frac > clip_limit:
        return (f"clipped ({100 * frac:.1f} % of the samples at full scale or flattened at "
                f"the extremes; more than {100 * clip_limit:g} %)")
    return None
