"""Stationary mains lines (50 or 60 Hz and their harmonics), found in a recording's own
long-term spectrum and notched out of its samples before any feature is computed.

A line is a bin of the recording's Welch spectrum (about 2 Hz resolution) that stands
``LINE_DB`` or more above the median of its neighbours, within a tolerance of ``k x 50`` or
``k x 60`` Hz, and that is **steady**: its power in each Welch segment stays within
``STEADY_DB`` of the others. Pick-up from the grid lasts as long as the recording, while an
impact's tone (a kick drum rings near 50-60 Hz) decays within it and must stay. A family
(50 or 60 Hz) is removed only when its **fundamental** is such a line: pick-up from the
grid always carries the fundamental, while a material's own tone (a resonance at 150 Hz
and its overtones at 300, 450 Hz) sits on multiples of 50 Hz without one at 50 Hz, and
must stay. Every line of an accepted family is then removed by a
narrow zero-phase IIR notch at the line's measured frequency.

Pure numpy/scipy: the trainer and the runtime call the same function through
:class:`~fingertip.models.vibration.spectrogram.Spectrogrammer`.
"""
from __future__ import annotations

import logging

import numpy as np
import scipy.signal

log = logging.getLogger(__name__)

MAINS_HZ = (50.0, 60.0)
RESOLUTION_HZ = 2.0
"""Target bin width of the long-term spectrum (Welch segments of 0.5 s, shorter for
recordings under 1 s: at least three half-overlapping segments)."""
COARSEST_HZ = 10.0
"""Recordings too short for this resolution are left alone: a 'line' would be 10 Hz wide
and could be content."""
GRID_TOLERANCE = 0.005
"""Relative frequency tolerance (grids stay within +-0.2 %; a resampled file may be off a
little more)."""
LINE_DB = 15.0
"""How far above its neighbours' median a bin must stand to be a line."""
STEADY_DB = 6.0
"""How far a line's power may swing between the Welch segments (0.5 s, half overlapping)
and still be a line: the grid's slow amplitude wander is about 1 dB; a struck object's
tone loses more than this between its first and its last segment."""
NEIGHBOUR_HZ = 25.0
"""Neighbours: the bins within this distance of a candidate, outside its own peak."""
MAX_HARMONIC = 40
NOTCH_BANDWIDTH_HZ = 4.0
"""-3 dB width of each notch: covers the grid's slow wander and the amplitude drift's
sidebands, and takes little of a broadband texture (4 Hz of a 100 Hz-wide band)."""
TOP_FRACTION = 0.45
"""Lines above this fraction of the rate are not looked for (anti-alias roll-off)."""


def find_mains_lines(x: np.ndarray, rate: float) -> list[float]:
    """Frequencies (Hz) of the stationary mains lines of samples ``x`` at ``rate``: the
    lines of every family (50 or 60 Hz) whose fundamental is a line; empty when the
    recording is too short to resolve lines."""
    x = np.asarray(x, dtype=np.float64)
    # at least three half-overlapping segments, so that steadiness can be judged
    nper = min(len(x) // 2, int(round(rate / RESOLUTION_HZ)))
    if nper < rate / COARSEST_HZ:
        return []
    f, _, seg = scipy.signal.spectrogram(x, rate, window="hann", nperseg=nper,
                                         noverlap=nper // 2, detrend="constant",
                                         scaling="density", mode="psd")
    p = seg.mean(axis=1)  # Welch's average of the same segments
    df = float(f[1] - f[0])
    lines: list[float] = []
    for f0 in MAINS_HZ:
        found = _family(f, p, seg, df, f0, rate)
        if found and found[0][0] == 1:
            lines.extend(fk for _, fk in found)
    # 300 Hz is the 6th of 50 and the 5th of 60: keep one notch per frequency
    out: list[float] = []
    for fk in sorted(lines):
        if not out or fk - out[-1] > NOTCH_BANDWIDTH_HZ / 2:
            out.append(fk)
    return out


def _family(f: np.ndarray, p: np.ndarray, seg: np.ndarray, df: float, f0: float,
            rate: float) -> list[tuple[int, float]]:
    """(harmonic number, measured frequency) of each steady line at a multiple of ``f0``
    (``p``: the mean of the segments' spectra ``seg``, bins x segments)."""
    found = []
    gap = 3 * df  # a Hann peak's main lobe is 2 bins each side
    for k in range(1, MAX_HARMONIC + 1):
        fk = k * f0
        if fk + NEIGHBOUR_HZ >= TOP_FRACTION * rate:
            break
        tol = max(GRID_TOLERANCE * fk, 1.5 * df)
        idx = np.flatnonzero(np.abs(f - fk) <= tol)
        if not len(idx):
            continue
        i = int(idx[np.argmax(p[idx])])
        dist = np.abs(f - f[i])
        neigh = p[(dist > gap) & (dist <= max(NEIGHBOUR_HZ, 4 * gap))]
        if not len(neigh):
            continue
        med = float(np.median(neigh))
        if p[i] > 0 and p[i] > med * 10 ** (LINE_DB / 10) and _steady(seg[i]):
            found.append((k, _refine(f, p, i, df)))
    return found


def _steady(power: np.ndarray) -> bool:
    """Whether a bin's power over the segments stays within :data:`STEADY_DB`."""
    lo, hi = float(power.min()), float(power.max())
    return lo > 0 and hi <= lo * 10 ** (STEADY_DB / 10)


def _refine(f: np.ndarray, p: np.ndarray, i: int, df: float) -> float:
    """Peak frequency by a parabola through the log power of the bin and its neighbours
    (a Hann window's peak is close to a parabola in dB)."""
    if i == 0 or i == len(p) - 1 or min(p[i - 1], p[i + 1]) <= 0:
        return float(f[i])
    a, b, c = np.log(p[i - 1]), np.log(p[i]), np.log(p[i + 1])
    den = a - 2 * b + c
    shift = 0.5 * (a - c) / den if den < 0 else 0.0
    return float(f[i] + float(np.clip(shift, -0.5, 0.5)) * df)


def notch_lines(x: np.ndarray, rate: float, lines: list[float]) -> np.ndarray:
    """``x`` with a zero-phase notch at each of ``lines`` (Hz); ``x`` itself when none."""
    if not lines:
        return x
    sos = np.vstack([scipy.signal.tf2sos(*scipy.signal.iirnotch(
        fk, fk / NOTCH_BANDWIDTH_HZ, fs=rate)) for fk in lines])
    y = scipy.signal.sosfiltfilt(sos, np.asarray(x, dtype=np.float64))
    return y.astype(np.asarray(x).dtype, copy=False) if np.asarray(x).dtype.kind == "f" \
        else y


def remove_mains(x: np.ndarray, rate: float) -> np.ndarray:
    """``x`` without its stationary mains lines (:func:`find_mains_lines`)."""
    lines = find_mains_lines(x, rate)
    if lines:
        log.debug("mains lines removed at %s Hz", ", ".join(f"{v:.1f}" for v in lines))
    return notch_lines(x, rate, lines)
