"""Join a fingertip recording with a reference force sensor by time, when the two clocks
disagree by an unknown offset.

The offset is estimated from the data: for each candidate lag, the reference force is read
at the fingertip's frame times shifted by the lag, and the best quadratic map from the counts
to that force is fitted; the lag whose fit explains the most wins (a multichannel
cross-correlation of the force: the counts need no calibration for it). A search over
+-``max_lag_s`` in 20 ms, then 5 ms steps; then 0.1 ms steps on the correlation of the time
derivatives (:func:`_refine`) and a parabola through the best three. The uncertainty is the
least-squares delay estimator's: the residual variance over the energy of the reference's
time derivative, inflated for correlated residuals.

A join that cannot be trusted is refused (:class:`AlignmentError`): too little overlap, a
reference that never moves, a fit that explains too little, a best lag at the edge of the
search, or two lags that fit equally well (periodic motion).
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from ...errors import EXIT_USAGE, Error
from ..nets.standardise import standardise

DEGREE = 2
REFINE_ROUNDS = 3
SEARCH_STEP_S = 0.02
COARSE_STEP_S = 0.005
FINE_STEP_S = 1e-4
SMOOTH_S = 0.005
"""Centred moving average on the reference before reading it (symmetric: no delay)."""
MIN_OVERLAP_S = 5.0
MIN_R2 = 0.8
AMBIGUOUS_R2 = 0.01
"""Another local best within this R2 of the best, more than 50 ms away: ambiguous."""
MAX_GAP_S = 0.02
"""Reference gaps longer than this (lost packets) leave the frames inside them unjoined."""
SETTLE_WINDOW_S = 0.025
SETTLE_N = 0.2


class AlignmentError(Error, ValueError):
    """The clocks cannot be aligned: the join would be wrong, so nothing is fitted (the data
    the user recorded or gave: exit status 2)."""

    exit_code = EXIT_USAGE


@dataclass
class Alignment:
    offset_s: float
    """Reference clock minus fingertip clock: an event at fingertip time t is stamped
    t + offset_s by the reference."""
    uncertainty_s: float
    r2: float
    lags_s: np.ndarray = field(repr=False)
    r2_curve: np.ndarray = field(repr=False)
    rows: int = 0

    def as_dict(self) -> dict:
        return {"offset_ms": round(self.offset_s * 1e3, 3),
                "uncertainty_ms": round(self.uncertainty_s * 1e3, 3),
                "r2": round(self.r2, 5), "rows": self.rows}


@dataclass
class Joined:
    times_s: np.ndarray
    """Fingertip clock."""
    counts: np.ndarray
    force: np.ndarray
    """(N, 3) reference force read at the frames' times."""
    dropped: dict[str, int]
    alignment: Alignment


def _smoothed(t: np.ndarray, f: np.ndarray, width_s: float = SMOOTH_S) -> np.ndarray:
    if len(t) < 3:
        return f
    dt = float(np.median(np.diff(t)))
    k = int(round(width_s / dt)) if dt > 0 else 0
    if k < 2:
        return f
    kern = np.ones(k) / k
    pad = np.pad(f, ((k // 2, k - 1 - k // 2), (0, 0)), mode="edge")
    return np.column_stack([np.convolve(pad[:, j], kern, mode="valid") for j in range(f.shape[1])])


def _design(counts: np.ndarray, degree: int = DEGREE) -> np.ndarray:
    """Polynomial features of the standardised counts: the gauges' response is not quite
    linear, and a misfit that a lag can partly absorb would bias the offset. No memory
    terms (hysteresis, creep models): they can imitate a delay, even a large one."""
    x = np.asarray(counts, float)
    z = standardise(x)[0]
    cols = [np.ones(len(x))]
    for d in range(1, degree + 1):
        for idx in itertools.combinations_with_replacement(range(z.shape[1]), d):
            cols.append(np.prod(z[:, idx], axis=1))
    return np.column_stack(cols)


def _gap_ok(t_ref: np.ndarray, tq: np.ndarray) -> np.ndarray:
    """Query times that fall inside the reference's span with no long gap around them."""
    i = np.searchsorted(t_ref, tq)
    ok = (i > 0) & (i < len(t_ref))
    ii = np.clip(i, 1, len(t_ref) - 1)
    return ok & (t_ref[ii] - t_ref[ii - 1] <= MAX_GAP_S)


def estimate_offset(t_ft: np.ndarray, counts: np.ndarray, t_ref: np.ndarray,
                    f_ref: np.ndarray, *, max_lag_s: float = 2.0, min_r2: float = MIN_R2
                    ) -> Alignment:
    """The offset between the clocks (see :class:`Alignment`); :class:`AlignmentError`
    when the data cannot determine it."""
    t_ft = np.asarray(t_ft, float)
    t_ref = np.asarray(t_ref, float)
    fr = _smoothed(t_ref, np.asarray(f_ref, float)[:, :2])
    lo, hi = max(t_ft[0], t_ref[0] - max_lag_s), min(t_ft[-1], t_ref[-1] + max_lag_s)
    if hi - lo < MIN_OVERLAP_S:
        raise AlignmentError(
            f"the recordings overlap by {max(hi - lo, 0):.1f} s at most (need "
            f"{MIN_OVERLAP_S:g} s within +-{max_lag_s:g} s): the clocks differ by more than "
            "the search range (--max-offset) or the recordings are of different sessions")
    # Frames whose shifted time stays inside the reference for every lag searched.
    use = (t_ft - max_lag_s > t_ref[0]) & (t_ft + max_lag_s < t_ref[-1])
    if np.count_nonzero(use) < 50:
        use = (t_ft > t_ref[0]) & (t_ft < t_ref[-1])
        max_lag_s = min(max_lag_s, 0.5)
    tq, x = t_ft[use], _design(np.asarray(counts, float)[use])
    q, _ = np.linalg.qr(x)

    def r2(lag: float) -> float:
        y = np.column_stack([np.interp(tq + lag, t_ref, fr[:, j]) for j in range(2)])
        y = y - y.mean(axis=0)
        sst = float(np.sum(y ** 2))
        if sst <= 0:
            return 0.0
        proj = q.T @ y
        return float(np.sum(proj ** 2)) / sst

    lags = np.arange(-max_lag_s, max_lag_s + SEARCH_STEP_S / 2, SEARCH_STEP_S)
    curve = np.array([r2(lag) for lag in lags])
    k = int(np.argmax(curve))
    if 0 < k < len(lags) - 1:  # then 5 ms steps around the best
        near = np.arange(lags[k] - SEARCH_STEP_S, lags[k] + SEARCH_STEP_S + 1e-9, COARSE_STEP_S)
        c2 = np.array([r2(lag) for lag in near])
        lags, curve = np.concatenate([lags, near]), np.concatenate([curve, c2])
        order = np.argsort(lags)
        lags, curve = lags[order], curve[order]
        k = int(np.argmax(curve))
    best = float(curve[k])
    if k in (0, len(lags) - 1):
        raise AlignmentError(
            f"the clocks cannot be aligned: the best match is at the edge of the search "
            f"(+-{max_lag_s:g} s); give a larger --max-offset")
    if best < min_r2:
        raise AlignmentError(
            f"the clocks cannot be aligned: at the best offset ({lags[k] * 1e3:+.0f} ms) the "
            f"counts explain only {100 * best:.0f} % of the reference force (need "
            f"{100 * min_r2:.0f} %): is the reference the sensor under this fingertip, with "
            "forces in its frame?")
    peaks = [i for i in range(1, len(curve) - 1)
             if curve[i] >= curve[i - 1] and curve[i] >= curve[i + 1]
             and abs(lags[i] - lags[k]) > 0.05 and curve[i] > best - AMBIGUOUS_R2]
    if peaks:
        raise AlignmentError(
            f"the clocks cannot be aligned: offsets {lags[k] * 1e3:+.0f} ms and "
            f"{lags[peaks[0]] * 1e3:+.0f} ms fit equally well (a periodic motion?); record "
            "presses of different sizes at irregular times")
    # The prediction is refitted at each refined offset: fitted at a wrong lag it carries
    # part of that lag's error (a few rounds converge).
    offset = float(lags[k])
    for _ in range(REFINE_ROUNDS):
        offset = _refine(tq, x, t_ref, fr, offset)
    fc = np.array([r2(offset)])
    return Alignment(offset, _uncertainty(tq, x, t_ref, fr, offset), float(fc[0]), lags, curve,
                     len(tq))


def _refine(tq, x, t_ref, fr, lag0: float, half_s: float = 0.03) -> float:
    """Fine offset: the fingertip's prediction (fitted at the coarse lag) against the
    reference by the correlation of their time derivatives. Derivatives weigh the ramps,
    where timing shows, and ignore what varies slowly (creep, a per-press gain from the
    contact height), which a lag would otherwise partly absorb."""
    y0 = np.column_stack([np.interp(tq + lag0, t_ref, fr[:, j]) for j in range(2)])
    coef, *_ = np.linalg.lstsq(x, y0, rcond=None)
    pred = x @ coef
    dp = np.gradient(pred, tq, axis=0)
    dt = float(np.median(np.diff(tq)))
    # The reference, averaged over one frame period, as the chip sees the force.
    frs = _smoothed(t_ref, fr, dt)
    fine = np.arange(lag0 - half_s, lag0 + half_s + FINE_STEP_S / 2, FINE_STEP_S)
    score = np.empty(len(fine))
    for i, lag in enumerate(fine):
        yr = np.column_stack([np.interp(tq + lag, t_ref, frs[:, j]) for j in range(2)])
        dr = np.gradient(yr, tq, axis=0)
        score[i] = float(np.sum(dp * dr) / np.sqrt(np.sum(dp ** 2) * np.sum(dr ** 2) + 1e-30))
    j = int(np.clip(np.argmax(score), 1, len(fine) - 2))
    y0_, y1, y2 = score[j - 1], score[j], score[j + 1]
    den = y0_ - 2 * y1 + y2
    step = 0.5 * (y0_ - y2) / den if den < 0 else 0.0
    return float(fine[j] + np.clip(step, -1, 1) * FINE_STEP_S)


def _uncertainty(tq, x, t_ref, fr, offset) -> float:
    y = np.column_stack([np.interp(tq + offset, t_ref, fr[:, j]) for j in range(2)])
    coef, *_ = np.linalg.lstsq(x, y, rcond=None)
    res = y - x @ coef
    h = 1e-3
    dy = np.column_stack([(np.interp(tq + offset + h, t_ref, fr[:, j])
                           - np.interp(tq + offset - h, t_ref, fr[:, j])) / (2 * h)
                          for j in range(2)])
    energy = float(np.sum(dy ** 2))
    if energy <= 0:
        return float("inf")
    var = float(np.mean(res ** 2))
    # Correlated residuals (hysteresis, creep) carry less information than white ones.
    r = res - res.mean(axis=0)
    rho = float(np.clip(np.sum(r[1:] * r[:-1]) / max(np.sum(r * r), 1e-30), 0.0, 0.99))
    return float(np.sqrt(var / energy * (1 + rho) / (1 - rho)))


def unsettled(t_ref: np.ndarray, f_ref: np.ndarray, tq: np.ndarray,
              window_s: float = SETTLE_WINDOW_S, tol_n: float = SETTLE_N) -> np.ndarray:
    """Query times where the reference moves by more than ``tol_n`` within +-``window_s``
    (a tap, a slip: a small timing error there is a large force error)."""
    a = np.searchsorted(t_ref, tq - window_s)
    b = np.searchsorted(t_ref, tq + window_s)
    out = np.zeros(len(tq), bool)
    for j in range(2):
        col = f_ref[:, j]
        for k in range(len(tq)):
            if b[k] - a[k] > 1:
                seg = col[a[k]:b[k]]
                if seg.max() - seg.min() > tol_n:
                    out[k] = True
    return out


def join(t_ft: np.ndarray, counts: np.ndarray, t_ref: np.ndarray, f_ref: np.ndarray,
         alignment: Alignment, *, valid: np.ndarray | None = None,
         settle_tol_n: float = SETTLE_N) -> Joined:
    """Read the reference at each frame's time (shifted by the offset), drop the frames in
    a reference gap, outside it, invalid (``valid`` False: timeouts, saturation), or
    unsettled."""
    t_ft = np.asarray(t_ft, float)
    t_ref = np.asarray(t_ref, float)
    f3 = np.zeros((len(t_ref), 3))
    f3[:, :np.asarray(f_ref).shape[1]] = f_ref
    fr = _smoothed(t_ref, f3)
    tq = t_ft + alignment.offset_s
    inside = _gap_ok(t_ref, tq)
    ok = np.ones(len(t_ft), bool) if valid is None else np.asarray(valid, bool)
    moving = unsettled(t_ref, fr, tq, tol_n=settle_tol_n) & inside & ok
    keep = inside & ok & ~moving
    force = np.column_stack([np.interp(tq[keep], t_ref, fr[:, j]) for j in range(3)])
    return Joined(t_ft[keep], np.asarray(counts, float)[keep], force,
                  {"outside_or_gap": int(np.count_nonzero(~inside)),
                   "invalid": int(np.count_nonzero(inside & ~ok)),
                   "unsettled": int(np.count_nonzero(moving))}, alignment)
