"""Can this dataset determine a map? Conditioning of the channels, dead channels, saturation,
directions: data that cannot is refused with its own exception."""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from .data import CalibrationData
from .errors import DeadChannelError, IllConditionedError, SingleDirectionError, TooFewRowsError
from .limits import CHANNELS, MAX_CONDITION, MIN_DIRECTION_RATIO, MIN_RESPONSE_R2, MIN_ROWS


def design_condition(counts: np.ndarray) -> tuple[float, np.ndarray]:
    """Condition number of the standardised affine design [z, 1] and its weakest direction
    (the right singular vector of the smallest singular value, over the channels)."""
    x = np.asarray(counts, np.float64)
    sd = x.std(axis=0)
    if np.any(sd == 0):
        return math.inf, (sd == 0).astype(float)
    z = (x - x.mean(axis=0)) / sd
    a = np.column_stack([z, np.ones(len(z))]) / math.sqrt(len(z))
    s, vt = np.linalg.svd(a, full_matrices=False)[1:]
    cond = float(s[0] / s[-1]) if s[-1] > 0 else math.inf
    return cond, vt[-1][:CHANNELS]


def _dependence(v: np.ndarray) -> str:
    w = np.abs(v) / max(np.abs(v).max(), 1e-300)
    chans = [i for i in np.argsort(-w) if w[i] > 0.1]
    if len(chans) < 2:
        return f"channel {chans[0]} is (nearly) constant"
    return (f"channels {', '.join(str(int(c)) for c in sorted(chans))} are (nearly) a linear "
            f"combination of each other (weights "
            f"{', '.join(f'{v[c]:+.2f}' for c in sorted(chans))}): identical or swapped wiring, "
            f"two inputs on one bridge, or a channel copied in software?")


def check_conditioning(counts: np.ndarray, max_condition: float = MAX_CONDITION) -> float:
    cond, v = design_condition(counts)
    if not cond <= max_condition:
        raise IllConditionedError(
            f"the standardised channels are ill-conditioned (condition number "
            f"{cond:.3g} > {max_condition:.3g}): {_dependence(v)}")
    return cond


def describe(data: CalibrationData, summary: dict[str, Any]) -> str:
    """One line on a checked dataset (``summary`` from :func:`check_dataset`): rows kept,
    sessions, what was dropped, the largest force and the condition number."""
    d = summary["dropped"]
    return (f"{summary['rows']} rows of {summary['rows_read']} "
            f"({summary['sessions']} session(s): {', '.join(data.sources)}"
            f"{'; unit ' + data.unit if data.unit else ''}); dropped {d['saturated']} "
            f"saturated and {d['timeout']} timed-out; forces up to "
            f"{summary['force_max_n']:.2f} N; condition number {summary['condition_number']:.3g}")


def check_dataset(data: CalibrationData, *, min_rows: int = MIN_ROWS,
                  max_condition: float = MAX_CONDITION) -> dict[str, Any]:
    """Refuse data that cannot determine the map (raises a :class:`CalibrationError`
    subclass); returns a summary and appends warnings (untared counts) to ``data``."""
    n = len(data)
    if n < min_rows:
        raise TooFewRowsError(f"{n} usable rows (of {data.rows_read} read); at least "
                              f"{min_rows} are needed, from several angles and depths")
    x, f = data.counts, data.force
    mag = np.hypot(f[:, 0], f[:, 1])
    if mag.max() <= 0:
        raise SingleDirectionError("every reference force is zero: nothing to calibrate")
    loaded = f[mag > 0.05 * mag.max()]
    sv = np.linalg.svd(loaded, compute_uv=False)
    ratio = float(sv[-1] / sv[0]) if sv[0] > 0 else 0.0
    if len(loaded) < 2 or ratio < MIN_DIRECTION_RATIO:
        ang = np.degrees(np.arctan2(loaded[:, 1], loaded[:, 0]))
        ang_known = sorted({round(float(a), 1) for a in data.angle_deg if np.isfinite(a)})
        what = (f"angles in the data: {', '.join(f'{a:g}' for a in ang_known)}" if ang_known
                else f"force directions {ang.min():.0f}..{ang.max():.0f} deg")
        raise SingleDirectionError(
            f"all forces point along one direction ({what}; spread ratio {ratio:.3f} < "
            f"{MIN_DIRECTION_RATIO}): four channels cannot be mapped to (Fx, Fy) from one "
            f"angle. Press from several directions (the paper: -50..50 deg in 10 deg steps)")
    for i in range(CHANNELS):
        span = float(np.ptp(x[:, i]))
        if span <= 2:
            raise DeadChannelError(
                f"channel {i} is constant ({x[0, i]:.0f} counts in every row): a dead gauge, "
                f"an open bridge or a stuck ADC")
    basis = np.column_stack([f, mag, np.ones(n)])
    coef, *_ = np.linalg.lstsq(basis, x, rcond=None)
    resid = x - basis @ coef
    r2 = 1 - resid.var(axis=0) / x.var(axis=0)
    for i in range(CHANNELS):
        if r2[i] < MIN_RESPONSE_R2:
            raise DeadChannelError(
                f"channel {i} does not respond to the force (R^2 = {r2[i]:.2f} against Fx, Fy "
                f"and |F|; {MIN_RESPONSE_R2} needed): a broken or unglued gauge, or a loose "
                f"wire; its counts vary by {np.ptp(x[:, i]):.0f} only through noise")
    cond = check_conditioning(x, max_condition)
    zero = mag < 0.02 * mag.max()
    if zero.sum() >= 5:
        off = np.median(x[zero], axis=0)
        span = np.ptp(x, axis=0)
        msg = ("counts at zero force sit at " + ", ".join(f"{o:.0f}" for o in off)
               + ": the data look untared. The model expects the same offsets at run time: "
                 "tare the device (`fingertip tare`) before calibrating and before use")
        # The most relaxed zero-force readings: right after unloading, creep and hysteresis
        # keep tared gauges tens of thousands of counts away from zero (the quick start's
        # simulated sweep did), while an untared bridge never comes near zero at all.
        rest = np.percentile(np.abs(x[zero]), 10, axis=0)
        if np.any(rest > 0.1 * span) and msg not in data.warnings:
            data.warnings.append(msg)
    return {"rows": n, "rows_read": data.rows_read, "dropped": dict(data.dropped),
            "condition_number": cond, "direction_ratio": ratio,
            "response_r2": [round(float(v), 4) for v in r2],
            "force_max_n": float(mag.max()), "sessions": int(len(np.unique(data.session)))}
