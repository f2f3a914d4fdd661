"""Force calibration: four strain channels (HX711 counts) -> planar force (Fx, Fy) in newtons.

From a calibration dataset (the paper's indenter protocol, docs/calibration.md) this module

1. loads and checks the data (:func:`load_dataset`, :func:`check_dataset`): data that cannot
   determine the map is refused with its own exception type (a subclass of
   :class:`CalibrationError`, each with a ``code``): too few rows, NaN/Inf, a dead channel,
   too many saturated rows, forces in a single direction, ill-conditioned channels;
2. holds whole cells of the protocol out for testing (:func:`split_holdout`): every reading
   of a held-out (angle, contact height) cell, in every sweep, loading and unloading, is on
   the test side, so no test reading has a neighbouring step or a repeat in training;
3. fits an affine map (SVD least squares with a conditioning check), polynomials (ridge,
   degree 2-3) and MLPs (:func:`~fingertip.models.mlp.train_mlp`), all on standardised
   inputs;
4. exports each to ONNX (float32, normalisation inside the graph), measures its latency with
   onnxruntime and its float32 error against the float64 reference, and picks the fastest
   model whose held-out RMSE is within ``bound_pct`` of the best (:func:`fit_calibration`).

Errors are vector errors: RMSE = sqrt(mean |F_est - F_true|^2) in N, MSE = its square in
N^2 (the per-component MSE is half of it). Training needs numpy and ``onnx``; the runtime
(:mod:`fingertip.models.force`) only numpy and onnxruntime.
"""
from __future__ import annotations

import csv
import json
import math
import os
import shutil
import statistics
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from itertools import combinations_with_replacement
from pathlib import Path
from typing import Any

import numpy as np

from .mlp import MLP, to_onnx, train_mlp
from .onnx_io import onnx_builder, open_session, save_graph

CHANNELS = 4
INT24_MIN, INT24_MAX = -(1 << 23), (1 << 23) - 1
MAX_CONDITION = 1e6
"""Refusal threshold for the condition number of the standardised affine design [z, 1].
A working fingertip stays below about 2e4: opposite gauges read almost opposite signals
(correlation about -0.99, condition about 150 on the virtual units), but each HX711 adds its
own noise (25-45 counts against a spread of about 1.5e5), which bounds the condition number
by about sqrt(5) x spread / noise even for perfectly matched gauges; 1e6 would take forces
near the ADC's limits. Above it, channels are copies or exact combinations of each other
(two inputs wired to one bridge, a channel duplicated in software)."""
MIN_ROWS = 40
MAX_SATURATED_FRACTION = 0.05
MIN_DIRECTION_RATIO = 0.05
"""Smallest/largest singular value of the (loaded) force vectors: below it the forces point
in one direction only (one angle), and the four channels cannot be mapped to two axes."""
MIN_RESPONSE_R2 = 0.2
"""A channel whose variance is less than this much explained by (Fx, Fy, |F|) is dead."""
DEFAULT_MODELS = ("affine", "poly2", "poly3", "mlp8", "mlp16x16", "mlp32x32")
MODEL_GROUPS = {"poly": ("poly2", "poly3"), "mlp": ("mlp8", "mlp16x16", "mlp32x32"),
                "all": DEFAULT_MODELS}
RIDGE_GRID = (0.0, 1e-10, 1e-8, 1e-6, 1e-4, 1e-2)
"""Ridge strengths tried for the polynomials, relative to the mean squared feature."""
COUNT_ALIASES = (tuple(f"c{i}" for i in range(CHANNELS)), tuple(f"ch{i}" for i in range(CHANNELS)))
FORCE_ALIASES = {"fx": ("fx", "fx_n"), "fy": ("fy", "fy_n")}
OPTIONAL_ALIASES = {"angle": ("angle_deg", "angle"), "height": ("height_mm", "height"),
                    "timeout_mask": ("timeout_mask",), "saturation_mask": ("saturation_mask",),
                    "trial": ("trial",), "sweep": ("sweep",), "unit": ("unit_seed", "unit"),
                    "phase": ("phase",)}
Progress = Callable[[str], None]


# --- errors -------------------------------------------------------------------------------

class CalibrationError(ValueError):
    """The data cannot determine the force model. ``code`` names the reason (stable, for
    scripts); the command line exits with status 2 for every one of them."""

    code = "calibration_error"


class DatasetFormatError(CalibrationError):
    """The file or folder is not a calibration dataset (missing columns, unreadable)."""

    code = "format"


class MixedUnitsError(CalibrationError):
    """Rows of several fingertips: each unit needs its own calibration."""

    code = "mixed_units"


class TooFewRowsError(CalibrationError):
    code = "too_few_rows"


class NonFiniteError(CalibrationError):
    code = "non_finite"


class SaturationError(CalibrationError):
    code = "saturated"


class DeadChannelError(CalibrationError):
    code = "dead_channel"


class SingleDirectionError(CalibrationError):
    """All forces along one direction: one angle only, the map to (Fx, Fy) is rank deficient."""

    code = "single_angle"


class IllConditionedError(CalibrationError):
    code = "ill_conditioned"


# --- data ---------------------------------------------------------------------------------

@dataclass
class CalibrationData:
    """Readings with their reference forces, after invalid rows were dropped."""

    counts: np.ndarray
    """(N, 4) float64 HX711 counts at gain 128, tared per session."""
    force: np.ndarray
    """(N, 2) float64 reference force (Fx, Fy) in N."""
    angle_deg: np.ndarray
    """(N,) indentation direction, NaN when unknown."""
    height_mm: np.ndarray
    """(N,) contact height below the nail tip, NaN when unknown."""
    session: np.ndarray
    """(N,) int: one session per file (one tare)."""
    trial: np.ndarray
    """(N,) int: trial within its session (-1 when unknown)."""
    phase: np.ndarray
    """(N,) str: loading / unloading, '' when unknown."""
    sources: list[str] = field(default_factory=list)
    dropped: dict[str, int] = field(default_factory=dict)
    """Rows dropped before fitting, by reason (timeout, saturated)."""
    rows_read: int = 0
    gain: int = 128
    unit: str = ""
    warnings: list[str] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.force)

    @property
    def has_grid(self) -> bool:
        return bool(np.all(np.isfinite(self.angle_deg)) and np.all(np.isfinite(self.height_mm)))

    def take(self, idx: np.ndarray) -> CalibrationData:
        return CalibrationData(self.counts[idx], self.force[idx], self.angle_deg[idx],
                               self.height_mm[idx], self.session[idx], self.trial[idx],
                               self.phase[idx], list(self.sources), dict(self.dropped),
                               len(idx), self.gain, self.unit, list(self.warnings))


def from_arrays(counts: np.ndarray, fx: np.ndarray, fy: np.ndarray, *,
                angle_deg: np.ndarray | None = None, height_mm: np.ndarray | None = None,
                session: np.ndarray | None = None, trial: np.ndarray | None = None,
                phase: np.ndarray | None = None, timeout_mask: np.ndarray | None = None,
                saturation_mask: np.ndarray | None = None, gain: int = 128,
                sources: Sequence[str] = (), unit: str = "",
                max_saturated_fraction: float = MAX_SATURATED_FRACTION) -> CalibrationData:
    """Build a dataset from arrays: rows whose chips timed out or saturated (masks, or
    counts at the 24-bit limits) are dropped and counted. Raises :class:`NonFiniteError`,
    :class:`DeadChannelError` (a chip that never answers) or :class:`SaturationError`."""
    counts = np.asarray(counts, dtype=np.float64)
    if counts.ndim != 2 or counts.shape[1] != CHANNELS:
        raise DatasetFormatError(f"need counts of shape (rows, {CHANNELS}), got {counts.shape}")
    n = len(counts)
    force = np.column_stack([np.asarray(fx, np.float64).reshape(-1),
                             np.asarray(fy, np.float64).reshape(-1)])
    if len(force) != n:
        raise DatasetFormatError(f"{n} rows of counts but {len(force)} reference forces")

    def col(a, fill, dtype):
        return np.full(n, fill, dtype) if a is None else np.asarray(a, dtype).reshape(-1)

    tmask = col(timeout_mask, 0, np.int64)
    smask = col(saturation_mask, 0, np.int64)
    if n == 0:
        raise TooFewRowsError("the dataset has no rows")
    # A chip that never answers is a dead channel, whatever its (meaningless) values say.
    for i in range(CHANNELS):
        out = int(np.count_nonzero(tmask >> i & 1))
        if out > n // 2:
            raise DeadChannelError(
                f"channel {i} timed out in {out} of {n} rows: its HX711 does not answer "
                f"(power, DOUT/SCK wiring or the chip itself)")
    timed_out = tmask & 0xF != 0
    bad = ~np.isfinite(counts) & ~timed_out[:, None]
    bad_f = ~np.isfinite(force)
    if bad.any() or bad_f.any():
        rows = np.flatnonzero(bad.any(axis=1) | bad_f.any(axis=1))
        what = []
        if bad.any():
            what.append(f"counts of channel(s) {sorted(set(np.nonzero(bad)[1].tolist()))}")
        if bad_f.any():
            what.append("reference forces")
        raise NonFiniteError(
            f"{len(rows)} row(s) hold NaN or infinite {' and '.join(what)} (first at row "
            f"{int(rows[0])}; rows count from 0 after the header): repair or remove them")
    at_limit = np.zeros(n, bool)
    fin = np.isfinite(counts)
    at_limit[fin.all(axis=1)] = ((counts[fin.all(axis=1)] <= INT24_MIN)
                                 | (counts[fin.all(axis=1)] >= INT24_MAX)).any(axis=1)
    saturated = ((smask & 0xF) != 0) | at_limit
    saturated &= ~timed_out
    n_sat, n_to = int(saturated.sum()), int(timed_out.sum())
    if n_sat > max_saturated_fraction * n:
        raise SaturationError(
            f"{n_sat} of {n} rows ({100 * n_sat / n:.1f} %) are saturated (a channel at the "
            f"24-bit limit {INT24_MIN} or {INT24_MAX}, or flagged by the device); more than "
            f"{100 * max_saturated_fraction:g} % means the forces exceed the ADC's range or "
            f"the tare is far off: tare at zero load, lower the gain or the largest force")
    keep = ~(saturated | timed_out)
    sess = col(session, 0, np.int64)
    data = CalibrationData(
        counts[keep], force[keep], col(angle_deg, np.nan, np.float64)[keep],
        col(height_mm, np.nan, np.float64)[keep], sess[keep], col(trial, -1, np.int64)[keep],
        (np.full(n, "", dtype=object) if phase is None
         else np.asarray(phase, dtype=object).reshape(-1))[keep],
        list(sources), {"timeout": n_to, "saturated": n_sat}, n, int(gain), str(unit))
    if n_sat:
        data.warnings.append(f"dropped {n_sat} saturated row(s) of {n}")
    if n_to:
        data.warnings.append(f"dropped {n_to} row(s) with a timed-out channel")
    return data


def _find(head: Sequence[str], names: Sequence[str]) -> str | None:
    lower = {h.strip().lower(): h for h in head}
    for n in names:
        if n in lower:
            return lower[n]
    return None


def _read_csv(path: Path) -> dict[str, list[str]]:
    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = [r for r in csv.reader(f) if r and not r[0].startswith("#")]
    except (OSError, UnicodeDecodeError) as e:
        raise DatasetFormatError(f"cannot read {path}: {getattr(e, 'strerror', None) or e}"
                                 ) from e
    if not rows:
        raise DatasetFormatError(f"{path} is empty")
    head = rows[0]
    cols: dict[str, list[str]] = {h: [] for h in head}
    for k, r in enumerate(rows[1:], start=2):
        if len(r) != len(head):
            raise DatasetFormatError(f"{path} line {k}: {len(r)} fields, the header has "
                                     f"{len(head)}")
        for h, v in zip(head, r, strict=True):
            cols[h].append(v)
    return cols


def _floats(values: list[str], what: str, path: Path) -> np.ndarray:
    try:
        return np.array([float(v) if v.strip() != "" else math.nan for v in values])
    except ValueError as e:
        raise DatasetFormatError(f"{path}: column {what} is not numeric ({e})") from None


def _columns_of(path: Path) -> tuple[dict[str, str], dict[str, list[str]]]:
    cols = _read_csv(path)
    head = list(cols)
    counts = next((names for names in COUNT_ALIASES
                   if all(_find(head, [n]) for n in names)), None)
    found = {k: _find(head, v) for k, v in FORCE_ALIASES.items()}
    if counts is None or None in found.values():
        raise DatasetFormatError(
            f"{path.name} is not a calibration CSV: it needs columns c0..c3 (or ch0..ch3, "
            f"as `fingertip export` writes) and fx, fy in newtons; it has {', '.join(head)}")
    mapping = {f"c{i}": _find(head, [n]) for i, n in enumerate(counts)}
    mapping.update(found)
    mapping.update({k: _find(head, v) for k, v in OPTIONAL_ALIASES.items()})
    return {k: v for k, v in mapping.items() if v is not None}, cols


def load_dataset(path: str | os.PathLike, *, unit: str | int | None = None,
                 max_saturated_fraction: float = MAX_SATURATED_FRACTION) -> CalibrationData:
    """Read a calibration CSV, or every calibration CSV of a folder (one session each).

    Columns (any order, others ignored): ``c0..c3`` or ``ch0..ch3`` (counts at gain 128,
    tared), ``fx``, ``fy`` (N), optionally ``angle_deg``, ``height_mm``, ``timeout_mask``,
    ``saturation_mask``, ``trial``, ``sweep``, ``phase``, ``unit_seed`` (the layout of
    ``fingertip sim dataset calibration``). Rows of several units are refused unless ``unit``
    selects one. A ``dataset.json`` beside the files may give the gain.
    """
    p = Path(path)
    if p.is_dir():
        files = sorted(f for f in p.glob("*.csv") if f.is_file())
        if not files:
            raise DatasetFormatError(f"{p} holds no CSV files")
    elif p.is_file():
        files = [p]
    else:
        raise DatasetFormatError(f"no such file or folder: {p}")
    gain = 128
    meta_file = (p if p.is_dir() else p.parent) / "dataset.json"
    if meta_file.is_file():
        try:
            gain = int(json.loads(meta_file.read_text(encoding="utf-8")).get("gain", 128))
        except (ValueError, OSError, AttributeError, TypeError):
            pass
    parts, skipped, sources = [], [], []
    for s, f in enumerate(files):
        try:
            mapping, cols = _columns_of(f)
        except DatasetFormatError as e:
            if len(files) == 1:
                raise
            skipped.append(f"{f.name} ({e})")
            continue
        arr = {k: (np.array(cols[v], dtype=object) if k == "phase"
                   else _floats(cols[v], v, f)) for k, v in mapping.items()}
        n = len(arr["fx"])
        cnt = np.column_stack([arr[f"c{i}"] for i in range(CHANNELS)])
        tmo = np.nan_to_num(arr.get("timeout_mask", np.zeros(n))).astype(np.int64) & 0xF
        bad = ~np.isfinite(cnt).all(axis=1) & (tmo == 0) | ~np.isfinite(arr["fx"]) \
            | ~np.isfinite(arr["fy"])
        if bad.any():
            raise NonFiniteError(
                f"{f.name}: {int(bad.sum())} row(s) hold empty, NaN or infinite counts or "
                f"forces (first on line {int(np.flatnonzero(bad)[0]) + 2}): repair or remove "
                f"them")
        sweep = arr.get("sweep", np.zeros(n))
        trial = arr.get("trial")
        # A session is one tare: one file. Trials restart with each sweep of a file.
        trial_id = np.full(n, -1, np.int64) if trial is None else \
            (np.nan_to_num(sweep).astype(np.int64) * 100_000
             + np.nan_to_num(trial, nan=-1).astype(np.int64))
        arr["session"] = np.full(n, s, np.int64)
        arr["trial_id"] = trial_id
        arr["unit"] = np.array([str(int(u)) if np.isfinite(u) else "" for u in arr["unit"]],
                               dtype=object) if "unit" in arr else np.full(n, "", dtype=object)
        parts.append(arr)
        sources.append(f.name)
    if not parts:
        raise DatasetFormatError(f"no calibration CSV in {p}: " + "; ".join(skipped))

    def cat(key, fill=None):
        if all(key in a for a in parts):
            return np.concatenate([a[key] for a in parts])
        if fill is None:
            return None
        return np.concatenate([a.get(key, np.full(len(a["fx"]), fill)) for a in parts])

    units = cat("unit", "")
    named = sorted({u for u in units if u != ""})
    if unit is not None:
        keep = units == str(unit)
        if not keep.any():
            raise MixedUnitsError(f"no rows of unit {unit} in {p} (units: "
                                  f"{', '.join(named) or 'not recorded'})")
        unit_name = str(unit)
    else:
        if len(named) > 1:
            raise MixedUnitsError(
                f"{p} holds rows of {len(named)} fingertips (units {', '.join(named)}): each "
                f"unit needs its own calibration; choose one (--unit {named[0]})")
        keep = np.ones(len(units), bool)
        unit_name = named[0] if named else ""
    nan = float("nan")

    def sel(a):
        return None if a is None else a[keep]

    data = from_arrays(
        np.column_stack([cat(f"c{i}") for i in range(CHANNELS)])[keep],
        cat("fx")[keep], cat("fy")[keep], angle_deg=sel(cat("angle", nan)),
        height_mm=sel(cat("height", nan)), session=sel(cat("session")),
        trial=sel(cat("trial_id")), phase=sel(cat("phase", "")),
        timeout_mask=sel(np.nan_to_num(cat("timeout_mask", 0)).astype(np.int64)),
        saturation_mask=sel(np.nan_to_num(cat("saturation_mask", 0)).astype(np.int64)),
        gain=gain, sources=sources, unit=unit_name,
        max_saturated_fraction=max_saturated_fraction)
    data.warnings[:0] = [f"skipped {s}" for s in skipped]
    return data


# --- checks -------------------------------------------------------------------------------

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
        if np.any(np.abs(off) > 0.1 * span) and msg not in data.warnings:
            data.warnings.append(msg)
    return {"rows": n, "rows_read": data.rows_read, "dropped": dict(data.dropped),
            "condition_number": cond, "direction_ratio": ratio,
            "response_r2": [round(float(v), 4) for v in r2],
            "force_max_n": float(mag.max()), "sessions": int(len(np.unique(data.session)))}


# --- held-out split -----------------------------------------------------------------------

def _cells(values: np.ndarray, decimals: int = 1) -> np.ndarray:
    r = np.round(values, decimals)
    _, inv = np.unique(r, return_inverse=True)
    return inv.reshape(-1)


def split_groups(data: CalibrationData, mode: str = "auto", blocks: int = 20
                 ) -> tuple[np.ndarray, str]:
    """Group id per row (rows of a group always stay on one side) and the mode used.

    ``grid``: one group per (angle, height) cell, across sessions (needs both columns);
    ``trial``: one group per trial of each session (needs ``trial``); ``blocks``: ``blocks``
    contiguous runs of rows per session (readings in recording order). ``auto`` takes the
    first of these the data allows."""
    if mode == "auto":
        mode = "grid" if data.has_grid else "trial" if np.all(data.trial >= 0) else "blocks"
    if mode == "grid":
        if not data.has_grid:
            raise DatasetFormatError("the grid split needs angle_deg and height_mm columns")
        ia, ih = _cells(data.angle_deg), _cells(data.height_mm)
        return ia * 10_000 + ih, mode
    if mode == "trial":
        if not np.all(data.trial >= 0):
            raise DatasetFormatError("the trial split needs a trial column")
        return data.session * 10_000_000 + data.trial, mode
    if mode == "blocks":
        g = np.empty(len(data), np.int64)
        for s in np.unique(data.session):
            idx = np.flatnonzero(data.session == s)
            g[idx] = s * 10_000 + (np.arange(len(idx)) * blocks) // max(len(idx), 1)
        return g, mode
    raise ValueError(f"unknown split {mode!r} (auto, grid, trial, blocks)")


def split_holdout(data: CalibrationData, mode: str = "auto", folds: int = 4, fold: int = 0
                  ) -> tuple[np.ndarray, np.ndarray, str]:
    """Training and test row indices (about 1/``folds`` held out) and a description.

    In the grid mode, cell (i, j) (i-th angle, j-th height, sorted) is held out when
    ``(i + j) % folds == fold``: every angle and every height appears on both sides, and
    the held-out cells are new combinations. Other modes hold out every ``folds``-th group
    in a fixed shuffled order."""
    groups, used = split_groups(data, mode)
    if used == "grid":
        ia, ih = _cells(data.angle_deg), _cells(data.height_mm)
        test = (ia + ih) % folds == fold
        if not test.any() or test.all():
            test = ia % folds == fold
        how = (f"grid: whole (angle, height) cells held out, cell (i, j) when (i + j) % "
               f"{folds} == {fold}; all readings of a cell (every sweep, loading and "
               f"unloading) on one side")
    else:
        uniq = np.unique(groups)
        order = np.random.default_rng(12345).permutation(len(uniq))
        held = set(uniq[order[fold::folds]].tolist())
        test = np.isin(groups, list(held))
        how = (f"{used}: whole {'trials' if used == 'trial' else 'blocks of readings'} "
               f"held out (1 in {folds}), never split between the sides")
    tr, te = np.flatnonzero(~test), np.flatnonzero(test)
    if len(te) == 0 or len(tr) < max(MIN_ROWS // 2, 10) or len(np.unique(groups[test])) < 1:
        raise TooFewRowsError(f"too few trials ({len(np.unique(groups))} groups) to hold some "
                              f"out for testing; record more angles, heights or trials")
    return tr, te, how


# --- models -------------------------------------------------------------------------------

def poly_terms(degree: int, channels: int = CHANNELS) -> list[tuple[int, ...]]:
    """Monomials of the standardised channels, degree 1..``degree``, in feature order."""
    return [t for k in range(1, degree + 1)
            for t in combinations_with_replacement(range(channels), k)]


@dataclass
class LinearFeatureMap:
    """F = phi(w) @ coef + intercept with w = ((counts - x_mean) / x_std) @ rotation and phi
    the monomials of w up to ``degree``. Affine: degree 1, no rotation. Polynomials: the
    rotation whitens (principal components of the standardised counts, unit variance), so
    that the monomials are not nearly collinear (opposite gauges read nearly opposite
    signals) and the coefficients stay small enough for float32 inference."""

    name: str
    degree: int
    x_mean: np.ndarray
    x_std: np.ndarray
    coef: np.ndarray
    intercept: np.ndarray
    ridge: float = 0.0
    condition: float = math.nan
    rotation: np.ndarray | None = None

    @property
    def kind(self) -> str:
        return "affine" if self.degree == 1 else "poly"

    @property
    def terms(self) -> list[tuple[int, ...]]:
        return poly_terms(self.degree, len(self.x_mean))

    @property
    def n_params(self) -> int:
        return int(self.coef.size + self.intercept.size)

    def features(self, counts: np.ndarray) -> np.ndarray:
        z = (np.asarray(counts, np.float64) - self.x_mean) / self.x_std
        if self.rotation is not None:
            z = z @ self.rotation
        return _monomials(z, self.terms)

    def predict(self, counts: np.ndarray) -> np.ndarray:
        """Float64 reference: (N, 2) forces in N."""
        return self.features(counts) @ self.coef + self.intercept

    def to_onnx(self, path: str | Path, metadata: dict | None = None) -> Path:
        return _linear_map_onnx(self, path, metadata or {})


def _monomials(z: np.ndarray, terms: Sequence[tuple[int, ...]]) -> np.ndarray:
    out = np.empty((z.shape[0], len(terms)))
    for k, t in enumerate(terms):
        v = z[:, t[0]]
        for c in t[1:]:
            v = v * z[:, c]
        out[:, k] = v
    return out


def _standardise(counts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    x = np.asarray(counts, np.float64)
    mean, sd = x.mean(axis=0), x.std(axis=0)
    if np.any(sd == 0):
        raise DeadChannelError(f"channel(s) {np.flatnonzero(sd == 0).tolist()} are constant")
    return (x - mean) / sd, mean, sd


def whitening(z: np.ndarray) -> np.ndarray:
    """Matrix p such that z @ p has uncorrelated unit-variance columns (PCA whitening of
    centred ``z``); components with no variance are left unscaled."""
    _, s, vt = np.linalg.svd(z - z.mean(axis=0), full_matrices=False)
    s = np.maximum(s, s[0] * 1e-9)
    return vt.T / s * math.sqrt(len(z))


def fit_affine(counts: np.ndarray, force: np.ndarray, *, max_condition: float = MAX_CONDITION,
               name: str = "affine") -> LinearFeatureMap:
    """Least squares on standardised channels, solved by SVD; refuses (raises
    :class:`IllConditionedError`) when the condition number exceeds ``max_condition``."""
    z, mean, sd = _standardise(counts)
    y = np.asarray(force, np.float64)
    a = np.column_stack([z, np.ones(len(z))])
    u, s, vt = np.linalg.svd(a, full_matrices=False)
    cond = float(s[0] / s[-1]) if s[-1] > 0 else math.inf
    if not cond <= max_condition:
        raise IllConditionedError(
            f"the standardised channels are ill-conditioned (condition number {cond:.3g} > "
            f"{max_condition:.3g}): {_dependence(vt[-1][:CHANNELS])}")
    w = vt.T @ ((u.T @ y) / s[:, None])
    return LinearFeatureMap(name, 1, mean, sd, w[:-1], w[-1], 0.0, cond)


def _ridge_solutions(p: np.ndarray, y: np.ndarray, lams: Sequence[float]):
    """Ridge on centred features (the intercept is not penalised), every lambda at once;
    lambdas are relative to the mean squared (centred) feature. Solved through the
    eigenvectors of the small Gram matrix (the whitened monomials are well conditioned)."""
    pm, ym = p.mean(axis=0), y.mean(axis=0)
    pc, yc = p - pm, y - ym
    e, v = np.linalg.eigh(pc.T @ pc)
    e = np.maximum(e, 0.0)
    scale = float(np.mean(e)) if len(e) else 1.0
    vty = v.T @ (pc.T @ yc)
    out = []
    for lam in lams:
        d = 1 / (e + lam * scale) if lam > 0 else \
            np.where(e > e.max() * 1e-13, 1 / np.maximum(e, 1e-300), 0.0)
        w = v @ (d[:, None] * vty)
        out.append((w, ym - pm @ w))
    return out


def fit_poly(counts: np.ndarray, force: np.ndarray, degree: int, *,
             groups: np.ndarray | None = None, ridge: float | None = None,
             name: str | None = None) -> LinearFeatureMap:
    """Polynomial of the standardised channels with ridge; ``ridge`` None picks it from
    :data:`RIDGE_GRID` by 3-fold cross-validation over ``groups`` (whole groups per fold)."""
    if degree < 1:
        raise ValueError("degree must be at least 1")
    z, mean, sd = _standardise(counts)
    y = np.asarray(force, np.float64)
    terms = poly_terms(degree)
    rot = whitening(z) if degree > 1 else None
    p = _monomials(z if rot is None else z @ rot, terms)
    if ridge is None:
        g = np.arange(len(z)) // max(1, len(z) // 12) if groups is None else groups
        uniq = np.unique(g)
        order = np.random.default_rng(7).permutation(len(uniq))
        err = np.zeros(len(RIDGE_GRID))
        for k in range(3):
            te = np.isin(g, uniq[order[k::3]])
            if te.all() or not te.any():
                continue
            for j, (w, b) in enumerate(_ridge_solutions(p[~te], y[~te], RIDGE_GRID)):
                err[j] += float(np.sum((p[te] @ w + b - y[te]) ** 2))
        ridge = float(RIDGE_GRID[int(np.argmin(err))])
    w, b = _ridge_solutions(p, y, [ridge])[0]
    pa = np.column_stack([p, np.ones(len(p))])
    ev = np.linalg.eigvalsh(pa.T @ pa)
    cond = float(math.sqrt(ev[-1] / ev[0])) if ev[0] > 0 else math.inf
    return LinearFeatureMap(name or f"poly{degree}", degree, mean, sd, w, b, ridge, cond, rot)


@dataclass
class MLPMap:
    """An MLP from :mod:`~fingertip.models.mlp` (its own normalisation) as a force map."""

    name: str
    mlp: MLP
    kind: str = "mlp"

    @property
    def n_params(self) -> int:
        return self.mlp.n_params

    def predict(self, counts: np.ndarray) -> np.ndarray:
        return self.mlp.forward(counts)

    def to_onnx(self, path: str | Path, metadata: dict | None = None) -> Path:
        return to_onnx(self.mlp, path, input_name="counts", output_name="force",
                       metadata=metadata)


def mlp_hidden(name: str) -> tuple[int, ...]:
    """``mlp16x16`` -> (16, 16)."""
    try:
        sizes = tuple(int(s) for s in name[3:].split("x"))
    except ValueError:
        sizes = ()
    if not name.startswith("mlp") or not sizes or min(sizes) < 1 or max(sizes) > 4096:
        raise ValueError(f"bad MLP name {name!r}: use mlpN or mlpNxM (hidden layer sizes)")
    return sizes


def fit_mlp(counts: np.ndarray, force: np.ndarray, hidden: tuple[int, ...], *,
            epochs: int = 1500, seed: int = 0, whiten: bool = True,
            weight_decay: float = 1e-4, name: str | None = None) -> MLPMap:
    """Train with Adam (batch 128, lr 5e-3, L2 ``weight_decay``, early stopping with
    patience epochs/10) on whitened channels: the principal components of the standardised
    counts, each scaled to unit variance. Opposite gauges read nearly opposite signals, so
    what tells contact heights apart hides in small components that plain standardisation
    leaves tiny (whitening: about 0.15 N instead of 0.2 N held out on the virtual units).
    The whitening is folded into the first layer, so the result is a plain
    :class:`~fingertip.models.mlp.MLP` whose ONNX graph standardises the raw counts."""
    z, mean, sd = _standardise(counts)
    p = whitening(z) if whiten else np.eye(z.shape[1])
    m = train_mlp(z @ p, force, hidden=hidden, epochs=epochs, batch=128, lr=5e-3,
                  weight_decay=weight_decay, patience=max(20, epochs // 10), seed=seed)
    # Fold: ((z @ p - m_w) / s_w) @ W1 + b1 == z @ W1' + b1', and z = (counts - mean) / sd.
    w1 = (p / m.x_std) @ m.weights[0]
    b1 = m.biases[0] - (m.x_mean / m.x_std) @ m.weights[0]
    folded = MLP([w1, *m.weights[1:]], [b1, *m.biases[1:]], mean, sd, m.task, m.y_offset,
                 m.y_scale, m.classes)
    return MLPMap(name or "mlp" + "x".join(str(h) for h in hidden), folded)


def expand_models(spec: str | Sequence[str]) -> list[str]:
    """``"affine,poly,mlp"`` -> model names; groups: poly, mlp, all; names: affine, polyN
    (N 1-4), mlpN[xM...]."""
    items = spec.split(",") if isinstance(spec, str) else list(spec)
    out: list[str] = []
    for it in (s.strip().lower() for s in items):
        if not it:
            continue
        names = MODEL_GROUPS.get(it, (it,))
        for n in names:
            if n == "affine":
                pass
            elif n.startswith("poly"):
                if n[4:] not in ("1", "2", "3", "4"):
                    raise ValueError(f"bad polynomial {n!r}: poly2, poly3 (or poly1, poly4)")
            elif n.startswith("mlp"):
                mlp_hidden(n)
            else:
                raise ValueError(f"unknown model {n!r}: affine, poly (poly2, poly3), "
                                 f"mlp (mlp8, mlp16x16, mlp32x32), or mlpNxM")
            if n not in out:
                out.append(n)
    if not out:
        raise ValueError("no models to fit")
    return out


def fit_model(name: str, counts: np.ndarray, force: np.ndarray, *,
              groups: np.ndarray | None = None, epochs: int = 1500, seed: int = 0,
              max_condition: float = MAX_CONDITION):
    if name == "affine":
        return fit_affine(counts, force, max_condition=max_condition)
    if name.startswith("poly"):
        return fit_poly(counts, force, int(name[4:]), groups=groups)
    return fit_mlp(counts, force, mlp_hidden(name), epochs=epochs, seed=seed, name=name)


# --- ONNX for the linear-feature maps -----------------------------------------------------

def _linear_map_onnx(m: LinearFeatureMap, path: str | Path, metadata: dict,
                     opset: int = 17) -> Path:
    _, TensorProto, helper, numpy_helper = onnx_builder()
    f32 = np.float32
    d = len(m.x_mean)
    inits = [numpy_helper.from_array(m.x_mean.astype(f32), "x_mean"),
             numpy_helper.from_array(m.x_std.astype(f32), "x_std"),
             numpy_helper.from_array(m.coef.astype(f32), "coef"),
             numpy_helper.from_array(m.intercept.astype(f32), "intercept")]
    nodes = [helper.make_node("Sub", ["counts", "x_mean"], ["xc"]),
             helper.make_node("Div", ["xc", "x_std"], ["zs" if m.rotation is not None
                                                       else "z"])]
    if m.rotation is not None:
        inits.append(numpy_helper.from_array(m.rotation.astype(f32), "rotation"))
        nodes.append(helper.make_node("MatMul", ["zs", "rotation"], ["z"]))
    # Monomials as outer products: q_k = vec(q_{k-1} (x) z), then one MatMul with the
    # coefficients at the positions of the sorted index tuples (zeros elsewhere).
    terms = m.terms
    full = np.zeros((sum(d ** k for k in range(1, m.degree + 1)), 2))
    offset = {k: sum(d ** j for j in range(1, k)) for k in range(1, m.degree + 1)}
    for t, c in zip(terms, m.coef, strict=True):
        pos = 0
        for i in t:
            pos = pos * d + i
        full[offset[len(t)] + pos] = c
    inits[2] = numpy_helper.from_array(full.astype(f32), "coef")
    feats = ["z"]
    if m.degree > 1:
        inits += [numpy_helper.from_array(np.array([2], np.int64), "ax2"),
                  numpy_helper.from_array(np.array([1], np.int64), "ax1"),
                  numpy_helper.from_array(np.array([0, -1], np.int64), "flat")]
        nodes.append(helper.make_node("Unsqueeze", ["z", "ax1"], ["z_row"]))
    prev = "z"
    for k in range(2, m.degree + 1):
        nodes += [helper.make_node("Unsqueeze", [prev, "ax2"], [f"col{k}"]),
                  helper.make_node("Mul", [f"col{k}", "z_row"], [f"outer{k}"]),
                  helper.make_node("Reshape", [f"outer{k}", "flat"], [f"q{k}"])]
        prev = f"q{k}"
        feats.append(prev)
    if len(feats) > 1:
        nodes.append(helper.make_node("Concat", feats, ["phi"], axis=1))
        phi = "phi"
    else:
        phi = "z"
    nodes += [helper.make_node("MatMul", [phi, "coef"], ["lin"]),
              helper.make_node("Add", ["lin", "intercept"], ["force"])]
    graph = helper.make_graph(
        nodes, f"fingertip_force_{m.name}",
        [helper.make_tensor_value_info("counts", TensorProto.FLOAT, ["batch", d])],
        [helper.make_tensor_value_info("force", TensorProto.FLOAT, ["batch", 2])], inits)
    return save_graph(graph, path, metadata, opset)


# --- evaluation ---------------------------------------------------------------------------

def rmse(pred: np.ndarray, force: np.ndarray) -> float:
    """Vector RMSE in N: sqrt(mean |pred - force|^2)."""
    d = np.asarray(pred, np.float64) - np.asarray(force, np.float64)
    return float(np.sqrt(np.mean(np.sum(d * d, axis=1)))) if len(d) else math.nan


def _by(keys: np.ndarray, pred: np.ndarray, force: np.ndarray) -> dict[str, float]:
    out = {}
    ok = np.array([k == k and k != "" for k in keys], bool)  # drops NaN and ''
    for k in sorted(set(keys[ok].tolist())):
        sel = keys == k
        label = f"{k:g}" if isinstance(k, float) else str(k)
        out[label] = round(rmse(pred[sel], force[sel]), 5)
    return out


def angle_keys(data: CalibrationData, step_deg: float = 10.0) -> np.ndarray:
    """Angles for the by-angle table: the recorded ones, or else the direction of the
    reference force rounded to ``step_deg`` (NaN for forces under 5 % of the largest)."""
    if np.all(np.isfinite(data.angle_deg)):
        return data.angle_deg
    mag = np.hypot(data.force[:, 0], data.force[:, 1])
    ang = np.degrees(np.arctan2(data.force[:, 1], data.force[:, 0]))
    out = np.round(ang / step_deg) * step_deg + 0.0
    out[mag < 0.05 * max(mag.max(), 1e-12)] = np.nan
    return out


def measure_latency(paths: dict[str, Path] | str | Path, sample: np.ndarray, *,
                    single_calls: int = 2000, batch: int = 1000, batch_repeats: int = 30,
                    rounds: int = 5):
    """Median microseconds per estimate with onnxruntime (one thread): one frame per call
    (``single_calls`` timed calls per model) and a batch of ``batch`` frames (per frame,
    ``batch_repeats`` calls). Several models are measured in interleaved ``rounds``, so
    that a machine getting busier or quieter does not favour one of them.

    ``paths``: {name: path} -> {name: (single_us, batch_us)}; one path -> (single, batch).
    """
    one_path = not isinstance(paths, dict)
    named = {"model": Path(paths)} if one_path else {k: Path(v) for k, v in paths.items()}
    x = np.asarray(sample, np.float32)
    one = np.ascontiguousarray(x[:1])
    many = np.ascontiguousarray(np.resize(x, (batch, x.shape[1])))
    sessions = {}
    for name, path in named.items():
        sess = open_session(path)
        inp = sess.get_inputs()[0].name
        for _ in range(100):
            sess.run(None, {inp: one})
        sess.run(None, {inp: many})
        sessions[name] = (sess, inp)
    clock = time.perf_counter_ns
    single: dict[str, list[int]] = {k: [] for k in named}
    batched: dict[str, list[int]] = {k: [] for k in named}
    rounds = max(1, min(rounds, single_calls, batch_repeats))
    for r in range(rounds):
        for name, (sess, inp) in sessions.items():
            t = single[name]
            for _ in range(single_calls // rounds + (r < single_calls % rounds)):
                t0 = clock()
                sess.run(None, {inp: one})
                t.append(clock() - t0)
            tb = batched[name]
            for _ in range(batch_repeats // rounds + (r < batch_repeats % rounds)):
                t0 = clock()
                sess.run(None, {inp: many})
                tb.append(clock() - t0)
    res = {k: (statistics.median(single[k]) / 1e3, statistics.median(batched[k]) / 1e3 / batch)
           for k in named}
    return res["model"] if one_path else res


def extreme_inputs(seed: int = 0, random_rows: int = 200) -> np.ndarray:
    """Counts at the 24-bit limits: every corner of {-2^23, 0, 2^23-1}^4 and random rows."""
    vals = np.array([INT24_MIN, 0, INT24_MAX], np.float64)
    grid = np.stack(np.meshgrid(*[vals] * CHANNELS, indexing="ij"), -1).reshape(-1, CHANNELS)
    rnd = np.random.default_rng(seed).integers(INT24_MIN, INT24_MAX + 1,
                                               (random_rows, CHANNELS)).astype(np.float64)
    return np.concatenate([grid, rnd])


def float32_error(path: str | Path, model, counts: np.ndarray) -> tuple[float, float]:
    """(max |ONNX float32 - float64 reference| in N on ``counts``, max of the same relative
    to max(|reference|, 1 N) on :func:`extreme_inputs`)."""
    sess = open_session(Path(path))
    name = sess.get_inputs()[0].name

    def run(x):
        return sess.run(None, {name: np.asarray(x, np.float32)})[0].astype(np.float64)

    x = np.asarray(counts, np.float64)
    in_range = float(np.max(np.abs(run(x) - model.predict(x)))) if len(x) else 0.0
    ext = extreme_inputs()
    ref = model.predict(ext)
    rel = np.abs(run(ext) - ref) / np.maximum(np.abs(ref), 1.0)
    return in_range, float(np.max(rel))


@dataclass
class ModelResult:
    name: str
    kind: str
    params: int
    rmse_n: float
    mse_n2: float
    train_rmse_n: float
    rmse_fx_n: float
    rmse_fy_n: float
    latency_us_single: float
    latency_us_batch: float
    float32_err_n: float
    float32_rel_err_extreme: float
    fit_s: float
    onnx: str
    by_angle: dict[str, float] = field(default_factory=dict)
    by_height: dict[str, float] = field(default_factory=dict)
    by_phase: dict[str, float] = field(default_factory=dict)
    ridge: float | None = None
    condition_number: float | None = None


@dataclass
class CalibrationReport:
    models: list[ModelResult]
    chosen: str
    bound_pct: float
    best_rmse_n: float
    rule: str
    split: str
    rows_train: int
    rows_test: int
    data: dict[str, Any]
    warnings: list[str]
    out_dir: str
    files: dict[str, str]

    def result(self, name: str) -> ModelResult:
        return next(m for m in self.models if m.name == name)

    @property
    def chosen_result(self) -> ModelResult:
        return self.result(self.chosen)

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["chosen_index"] = [m.name for m in self.models].index(self.chosen)
        return d

    def table(self) -> str:
        """The speed-against-error table (markdown)."""
        lines = ["| model | params | held-out RMSE (N) | MSE (N^2) | train RMSE (N) | "
                 "1 frame (us, p50) | in a batch of 1000 (us/frame) | float32 err (N) | |",
                 "|---|---:|---:|---:|---:|---:|---:|---:|---|"]
        for m in sorted(self.models, key=lambda r: r.latency_us_single):
            lines.append(
                f"| {m.name} | {m.params} | {m.rmse_n:.3f} | {m.mse_n2:.4f} | "
                f"{m.train_rmse_n:.3f} | {m.latency_us_single:.1f} | "
                f"{m.latency_us_batch:.3f} | {m.float32_err_n:.1e} | "
                f"{'**chosen**' if m.name == self.chosen else ''} |")
        return "\n".join(lines)

    def markdown(self) -> str:
        src = ", ".join(self.data.get("sources") or [])
        out = ["# Force calibration", "",
               f"Data: {self.data.get('rows', '?')} rows used of {self.data.get('rows_read', '?')}"
               f" read{' from ' + src if src else ''}; dropped "
               f"{self.data.get('dropped', {})}. Held out: {self.split}; "
               f"{self.rows_train} training rows, {self.rows_test} test rows.", "",
               "Errors are vector errors over (Fx, Fy): RMSE = sqrt(mean |F_est - F|^2). "
               "Latency: onnxruntime, one thread, median.", "",
               self.table(), "", f"Chosen: **{self.chosen}**. {self.rule}", ""]
        for title, key in (("contact height (mm)", "by_height"), ("angle (deg)", "by_angle"),
                           ("phase", "by_phase")):
            keys = list(getattr(self.models[0], key))
            if not keys:
                continue
            if key != "by_phase":
                keys.sort(key=float)
            out += [f"## Held-out RMSE (N) by {title}", "",
                    "| " + title + " | " + " | ".join(m.name for m in self.models) + " |",
                    "|---|" + "---:|" * len(self.models)]
            for k in keys:
                out.append(f"| {k} | " + " | ".join(
                    f"{getattr(m, key).get(k, math.nan):.3f}" for m in self.models) + " |")
            out.append("")
        if self.warnings:
            out += ["## Warnings", ""] + [f"- {w}" for w in self.warnings] + [""]
        return "\n".join(out)


def choose(results: Sequence[ModelResult], bound_pct: float) -> tuple[str, float, str]:
    """The fastest (single-frame p50) model whose held-out RMSE is within ``bound_pct``
    percent of the best; latencies within 5 % of each other count as a tie (the timing
    noise of a shared machine), which the lower RMSE wins."""
    best = min(r.rmse_n for r in results)
    limit = best * (1 + bound_pct / 100)
    ok = [r for r in results if r.rmse_n <= limit + 1e-12]
    fastest = min(r.latency_us_single for r in ok)
    tied = [r for r in ok if r.latency_us_single <= fastest * 1.05]
    pick = min(tied, key=lambda r: (r.rmse_n, r.latency_us_single))
    rule = (f"Rule: the fastest model (one frame, p50) whose held-out RMSE is within "
            f"{bound_pct:g} % of the best ({best:.3f} N, so <= {limit:.3f} N); latencies "
            f"within 5 % count as equal and the lower RMSE wins.")
    return pick.name, best, rule


def _plot(report: CalibrationReport, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    has_h = bool(report.models[0].by_height)
    fig, axes = plt.subplots(1, 2 if has_h else 1, figsize=(11 if has_h else 6, 4.2),
                             squeeze=False)
    ax = axes[0, 0]
    limit = report.best_rmse_n * (1 + report.bound_pct / 100)
    for m in report.models:
        chosen = m.name == report.chosen
        ax.scatter([m.latency_us_single], [m.rmse_n], s=80 if chosen else 40,
                   marker="*" if chosen else "o", zorder=3,
                   color="tab:red" if chosen else "tab:blue")
        ax.annotate(m.name, (m.latency_us_single, m.rmse_n), textcoords="offset points",
                    xytext=(5, 4), fontsize=8)
    ax.axhline(limit, ls="--", color="gray", lw=1,
               label=f"best + {report.bound_pct:g} % ({limit:.3f} N)")
    lat = [m.latency_us_single for m in report.models]
    if max(lat) > 10 * min(lat):
        ax.set_xscale("log")
    ax.set_xlabel("latency per estimate, one frame (us, onnxruntime p50)")
    ax.set_ylabel("held-out RMSE (N)")
    ax.set_title(f"speed against error (chosen: {report.chosen})")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    if has_h:
        ax2 = axes[0, 1]
        for m in report.models:
            ks = sorted(m.by_height, key=float)
            ax2.plot([float(k) for k in ks], [m.by_height[k] for k in ks], marker="o",
                     label=m.name, lw=2.5 if m.name == report.chosen else 1)
        ax2.set_xlabel("contact height below the nail tip (mm)")
        ax2.set_ylabel("held-out RMSE (N)")
        ax2.set_title("error by contact height")
        ax2.grid(alpha=0.3)
        ax2.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def model_metadata(model, data: CalibrationData, train: CalibrationData, *,
                   heldout: dict[str, float] | None = None, split: str = "") -> dict[str, Any]:
    """The ONNX metadata :class:`~fingertip.models.force.ForceModel` reads."""
    from .. import __version__

    x = train.counts
    meta = {
        "fingertip_model": "force", "model": model.name, "kind": model.kind,
        "channels": CHANNELS, "input": "counts", "output": "force", "outputs": ["fx", "fy"],
        "units": "N",
        "counts_scale": "1 input unit = 1 HX711 count at gain counts_gain, tared",
        "counts_gain": data.gain, "saturation_limits": [INT24_MIN, INT24_MAX],
        "counts_min": [float(v) for v in x.min(axis=0)],
        "counts_max": [float(v) for v in x.max(axis=0)],
        "force_max_n": float(np.hypot(*train.force.T).max()),
        "train_rmse_n": round(rmse(model.predict(x), train.force), 5),
        "params": model.n_params, "rows_train": len(train), "unit": data.unit,
        "dataset": ", ".join(data.sources), "split": split,
        "created_by": f"fingertip {__version__} calibrate fit",
    }
    if heldout:
        meta.update(heldout)
    return meta


def fit_calibration(data: CalibrationData, out_dir: str | os.PathLike, *,
                    models: str | Sequence[str] = DEFAULT_MODELS, bound_pct: float = 10.0,
                    split: str = "auto", epochs: int = 1500, seed: int = 0,
                    max_condition: float = MAX_CONDITION, plot: bool = True,
                    single_calls: int = 2000, progress: Progress | None = None,
                    extra_metadata: dict[str, Any] | None = None) -> CalibrationReport:
    """Check ``data``, hold out whole cells/trials, fit ``models``, export each to
    ``out_dir/force_<name>.onnx``, measure them, choose one (copied to ``force.onnx``) and
    write ``calibration.json``, ``calibration.md`` and ``speed_vs_error.png``.
    ``extra_metadata``: more ONNX metadata (e.g. the device's serial number)."""
    say = progress or (lambda _msg: None)
    if not (bound_pct >= 0 and math.isfinite(bound_pct)):
        raise ValueError(f"the error bound must be a percentage >= 0, not {bound_pct}")
    names = expand_models(models)
    summary = check_dataset(data, max_condition=max_condition)
    tr_idx, te_idx, how = split_holdout(data, split)
    train, test = data.take(tr_idx), data.take(te_idx)
    groups, _ = split_groups(train, split)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    results: list[ModelResult] = []
    rows = []
    for k, name in enumerate(names):
        say(f"[{k + 1}/{len(names)}] fitting {name} on {len(train)} rows ...")
        t0 = time.perf_counter()
        model = fit_model(name, train.counts, train.force, groups=groups, epochs=epochs,
                          seed=seed, max_condition=max_condition)
        fit_s = time.perf_counter() - t0
        pred = model.predict(test.counts)
        err = rmse(pred, test.force)
        held = {"heldout_rmse_n": round(err, 5), "heldout_mse_n2": round(err * err, 6),
                "rows_test": len(test), **(extra_metadata or {})}
        path = model.to_onnx(out / f"force_{name}.onnx",
                             model_metadata(model, data, train, heldout=held, split=how))
        rows.append((name, model, pred, err, path, fit_s))
        say(f"[{k + 1}/{len(names)}] {name}: held-out RMSE {err:.3f} N, fitted in "
            f"{fit_s:.1f} s")
    say(f"timing {len(rows)} model(s) with onnxruntime ...")
    lat = measure_latency({r[0]: r[4] for r in rows}, test.counts, single_calls=single_calls)
    for name, model, pred, err, path, fit_s in rows:
        d = pred - test.force
        f32, f32x = float32_error(path, model, test.counts)
        lat1, latb = lat[name]
        results.append(ModelResult(
            name, model.kind, model.n_params, round(err, 5), round(err * err, 6),
            round(rmse(model.predict(train.counts), train.force), 5),
            round(float(np.sqrt(np.mean(d[:, 0] ** 2))), 5),
            round(float(np.sqrt(np.mean(d[:, 1] ** 2))), 5),
            round(lat1, 3), round(latb, 4), float(f"{f32:.3g}"), float(f"{f32x:.3g}"),
            round(fit_s, 3), path.name, _by(angle_keys(test), pred, test.force),
            _by(test.height_mm, pred, test.force), _by(test.phase, pred, test.force),
            getattr(model, "ridge", None) if model.kind == "poly" else None,
            getattr(model, "condition", None) if model.kind != "mlp" else None))
    chosen, best, rule = choose(results, bound_pct)
    shutil.copyfile(out / f"force_{chosen}.onnx", out / "force.onnx")
    summary["sources"] = data.sources
    summary["unit"] = data.unit
    files = {"chosen": "force.onnx", "json": "calibration.json", "markdown": "calibration.md"}
    report = CalibrationReport(results, chosen, float(bound_pct), best, rule, how, len(train),
                               len(test), summary, list(data.warnings), str(out), files)
    if plot:
        files["plot"] = "speed_vs_error.png"
        _plot(report, out / files["plot"])
    (out / files["json"]).write_text(json.dumps(report.as_dict(), indent=1) + "\n",
                                     encoding="utf-8")
    (out / files["markdown"]).write_text(report.markdown(), encoding="utf-8")
    return report
