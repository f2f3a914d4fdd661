"""A calibration dataset: counts and reference forces in arrays (:class:`CalibrationData`),
built from arrays or read from the CSV files of ``fingertip export`` / ``sim dataset``."""
from __future__ import annotations

import csv
import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ....protocol import INT24_MAX, INT24_MIN
from .errors import (
    DatasetFormatError,
    DeadChannelError,
    MixedUnitsError,
    NonFiniteError,
    SaturationError,
    TooFewRowsError,
)
from .limits import CHANNELS, MAX_SATURATED_FRACTION

COUNT_ALIASES = (tuple(f"c{i}" for i in range(CHANNELS)), tuple(f"ch{i}" for i in range(CHANNELS)))
FORCE_ALIASES = {"fx": ("fx", "fx_n"), "fy": ("fy", "fy_n")}
OPTIONAL_ALIASES = {"angle": ("angle_deg", "angle"), "height": ("height_mm", "height"),
                    "timeout_mask": ("timeout_mask",), "saturation_mask": ("saturation_mask",),
                    "trial": ("trial",), "sweep": ("sweep",), "unit": ("unit_seed", "unit"),
                    "phase": ("phase",)}


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
