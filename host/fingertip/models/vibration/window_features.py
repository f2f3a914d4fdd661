"""Per-window features of a band power spectrogram: gain-free log windows (each divided by
its own mean power), their summaries over time (mean, deviation, frame-to-frame change, 90th
percentile), where windows start, and a window's level. Numpy only."""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .features import FLOOR_DB, HOP_S, KNOWN_STATS, STATS


def log_window(power: np.ndarray, floor_db: float = FLOOR_DB, split: int = 0
               ) -> np.ndarray:
    """dB relative to each window's mean band power, floored at ``floor_db``.

    ``power``: (..., frames, bands), one window per leading index. Gain-free: scaling the
    input by any factor gives the same values. Silence (all zero) gives ``floor_db``.
    ``split``: the columns from ``split`` on (the linear bins of
    :attr:`FeatureConfig.linear_bins`) are relative to their own mean, so that each view
    of the spectrum is the same as on its own.
    """
    p = np.asarray(power)
    if 0 < split < p.shape[-1]:
        return np.concatenate([log_window(p[..., :split], floor_db),
                               log_window(p[..., split:], floor_db)], axis=-1)
    m = p.mean(axis=(-2, -1), keepdims=True)
    tiny = np.finfo(p.dtype).tiny if p.dtype.kind == "f" else 1e-300
    silent = m <= tiny
    ratio = p / np.where(silent, 1, m)
    ratio += p.dtype.type(10.0 ** (floor_db / 10)) if p.dtype.kind == "f" else \
        10.0 ** (floor_db / 10)
    out = np.log10(ratio)
    out *= 10
    np.maximum(out, floor_db, out=out)  # float32 rounding must not step below the floor
    if silent.any():
        out[np.broadcast_to(silent, out.shape)] = floor_db
    return out


def pooled(logwin: np.ndarray, stats: Sequence[str] = STATS) -> np.ndarray:
    """Summary of windows of log band power, (..., frames, bands) -> (..., len(stats) x
    bands): the mean over time (spectral shape), the standard deviation (how much each band
    fluctuates: clicks, impacts, stick-slip), the mean absolute change between
    consecutive frames (texture and modulation) and the 90th percentile (``p90``: the
    loud moments of each band, robust to a single click), in the order of ``stats``."""
    parts = []
    for s in stats:
        if s == "mean":
            parts.append(logwin.mean(axis=-2))
        elif s == "std":
            parts.append(logwin.std(axis=-2))
        elif s == "flux":
            parts.append(np.abs(np.diff(logwin, axis=-2)).mean(axis=-2)
                         if logwin.shape[-2] > 1 else np.zeros(logwin.shape[:-2]
                                                                + logwin.shape[-1:],
                                                                logwin.dtype))
        elif s == "p90":
            parts.append(_percentile_over_time(logwin, 0.9))
        else:
            raise ValueError(f"unknown statistic {s!r} (one of {KNOWN_STATS})")
    return np.concatenate(parts, axis=-1)


def window_starts(n_frames: int, window_frames: int, step_s: float, hop_s: float = HOP_S
                  ) -> np.ndarray:
    """First frame of each window of ``window_frames`` frames every ``step_s`` seconds."""
    if n_frames < window_frames:
        return np.zeros(0, dtype=np.intp)
    step = step_s / hop_s
    n = int((n_frames - window_frames) / step + 1e-9) + 1
    return np.rint(np.arange(n) * step).astype(np.intp)


def gather_windows(power: np.ndarray, starts: np.ndarray, window_frames: int) -> np.ndarray:
    """(windows, window_frames, bands) copies of the frames of each window."""
    idx = starts[:, None] + np.arange(window_frames)
    return power[idx]


def level_db(x: np.ndarray) -> float:
    """RMS level in dB of the samples' units (dBFS for WAV/FLAC); -inf for silence."""
    x = np.asarray(x, dtype=np.float64)
    if not len(x):
        return -math.inf
    ms = float(np.mean(np.square(x - x.mean())))
    return 10 * math.log10(ms) if ms > 0 else -math.inf


def _percentile_over_time(logwin: np.ndarray, q: float) -> np.ndarray:
    """``np.percentile(logwin, 100 q, axis=-2)`` (linear interpolation) by a partial sort
    of contiguous rows: about twice as fast on the trainer's windows."""
    n = logwin.shape[-2]
    k = q * (n - 1)
    lo = int(k)
    hi = min(lo + 1, n - 1)
    rows = np.ascontiguousarray(np.swapaxes(logwin, -1, -2))
    part = np.partition(rows, (lo, hi), axis=-1)
    return (part[..., lo] + (k - lo) * (part[..., hi] - part[..., lo])).astype(logwin.dtype,
                                                                              copy=False)
