"""``calibrate record``: a fingertip and a reference force sensor recorded side by side,
joined by time (:mod:`.align`), and handed to the fitting (:func:`.calibrate.fit_calibration`).

The fingertip comes live (:func:`record_session`) or from a ``fingertip export`` CSV
(:func:`load_fingertip_csv`); the reference from any :class:`~fingertip.reference.WrenchSource`
(RDT; a ROS 2 WrenchStamped subscriber from the middleware issue fits the same seam) or a
CSV. Outputs: the usual ``force.onnx`` and report files, ``joined.csv`` (what was fitted),
``alignment.json`` and ``calibration_report.png`` (predicted against reference per axis,
residuals, hysteresis loops, held-out RMSE).
"""
from __future__ import annotations

import csv
import json
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ...outputs import atomic_output, write_text
from ...reference import ReferenceError, ReferenceSamples
from .align import Alignment, AlignmentError, Joined, estimate_offset, join
from ..nets.figures import pyplot, save_png
from .calibrate import (
    CHANNELS,
    CalibrationReport,
    DatasetFormatError,
    fit_calibration,
    from_arrays,
    split_holdout,
)

log = logging.getLogger(__name__)
TRIAL_ON_N = 0.15
"""A new trial starts when the reference rises above this after being below it."""


@dataclass
class FingertipRecording:
    times_s: np.ndarray
    counts: np.ndarray
    timeout_mask: np.ndarray
    saturation_mask: np.ndarray
    gain: int = 128
    serial: str = ""

    @property
    def valid(self) -> np.ndarray:
        return ((self.timeout_mask | self.saturation_mask) & 0xF) == 0


def record_session(ft, source, duration_s: float, *, tare_samples: int = 16,
                   before: Callable[[], None] | None = None,
                   progress: Callable[[str], None] | None = None) -> tuple[
                       FingertipRecording, ReferenceSamples]:
    """Tare the fingertip (nothing may touch it), start the reference, stream for
    ``duration_s`` and return both recordings in the host's clock (``Frame.host_time``)."""
    say = progress or (lambda _m: None)
    say(f"taring with {tare_samples} readings: do not touch the fingertip ...")
    ft.tare(samples=tare_samples)
    source.start()
    rows = []
    try:
        ft.start()
        if before is not None:
            before()
        say(f"recording {duration_s:g} s: press the fingertip from every direction you "
            "will use, slowly, up to the largest force you need")
        t_end = time.monotonic() + duration_s
        while time.monotonic() < t_end:
            f = ft.read(timeout=0.5)
            if f is not None:
                rows.append(f)
    finally:
        ref = source.stop()
        try:
            ft.stop()
        except Exception as e:  # the recording is kept; a failed STOP is only reported
            log.warning("stopping the stream failed: %s", e)
    n = len(rows)
    counts = np.array([f.counts[:CHANNELS] for f in rows], float).reshape(n, CHANNELS)
    rec = FingertipRecording(np.array([f.host_time for f in rows]), counts,
                             np.array([f.timeout_mask for f in rows], np.int64),
                             np.array([f.saturation_mask for f in rows], np.int64),
                             int(ft.info.gain), str(getattr(ft, "serial_number", "") or ""))
    if n < 50:
        raise ReferenceError(f"only {n} frames came from the fingertip in {duration_s:g} s")
    return rec, ref


def load_fingertip_csv(path: str | Path, time_column: str = "host_time") -> FingertipRecording:
    """A ``fingertip export`` CSV: ``time_column`` (host_time or unix_time), ch0..ch3 and
    the masks."""
    from ...reference.csvref import ReferenceFormatError

    p = Path(path)
    try:
        with p.open(newline="", encoding="utf-8") as fh:
            rows = list(csv.DictReader(fh))
    except (OSError, UnicodeDecodeError) as e:
        raise ReferenceFormatError(f"cannot read {p}: {e}") from None
    need = [time_column] + [f"ch{i}" for i in range(CHANNELS)]
    have = list(rows[0]) if rows else []
    missing = [c for c in need if c not in have]
    if missing:
        raise ReferenceFormatError(f"{p}: no column {', '.join(missing)} (a `fingertip "
                                   f"export` CSV has {', '.join(need)})")
    try:
        t = np.array([float(r[time_column]) for r in rows])
        counts = np.array([[float(r[f"ch{i}"]) for i in range(CHANNELS)] for r in rows])
        tm = np.array([int(r.get("timeout_mask") or 0) for r in rows], np.int64)
        sm = np.array([int(r.get("saturation_mask") or 0) for r in rows], np.int64)
    except ValueError:
        raise ReferenceFormatError(f"{p}: a time or count is not a number") from None
    if np.any(np.diff(t) <= 0):
        raise ReferenceFormatError(f"{p}: {time_column} does not increase row by row")
    return FingertipRecording(t, counts, tm, sm)


def trials_of(force: np.ndarray, on_n: float = TRIAL_ON_N) -> np.ndarray:
    """Trial number of each row: a trial begins where the force rises above ``on_n``."""
    mag = np.hypot(force[:, 0], force[:, 1])
    above = mag > on_n
    starts = above & ~np.concatenate([[False], above[:-1]])
    return np.cumsum(starts)


def align_and_join(rec: FingertipRecording, ref: ReferenceSamples, *, max_lag_s: float = 2.0,
                   settle_tol_n: float = 0.2) -> Joined:
    """Check the reference, estimate the offset, join; raise ReferenceError /
    AlignmentError (one clear line each) rather than join badly."""
    ref.require_usable()
    ok = rec.valid
    if np.count_nonzero(ok) < 50:
        raise ReferenceError("fewer than 50 valid fingertip frames (timeouts or saturation "
                             "everywhere): run `fingertip check` first")
    al = estimate_offset(rec.times_s[ok], rec.counts[ok], ref.times_s, ref.force,
                         max_lag_s=max_lag_s)
    return join(rec.times_s, rec.counts, ref.times_s, ref.force, al, valid=ok,
                settle_tol_n=settle_tol_n)


def fit_joined(joined: Joined, out_dir: str | Path, *, gain: int = 128, unit: str = "",
               device_serial: str = "", sources: tuple[str, ...] = (), plot: bool = True,
               **fit_kw: Any) -> CalibrationReport:
    """Fit the joined rows (trials held out whole) and write the report files."""
    f = joined.force
    data = from_arrays(joined.counts, f[:, 0], f[:, 1], trial=trials_of(f), gain=gain,
                       sources=sources, unit=unit)
    meta = {"device_serial": device_serial, "reference": ", ".join(sources),
            "clock_offset_ms": round(joined.alignment.offset_s * 1e3, 3),
            "clock_offset_uncertainty_ms": round(joined.alignment.uncertainty_s * 1e3, 3)}
    out = Path(out_dir)
    report = fit_calibration(data, out, split=fit_kw.pop("split", "trial"), plot=plot,
                             extra_metadata=meta, **fit_kw)
    write_joined(joined, out / "joined.csv")
    write_text(out / "alignment.json", json.dumps(
        {**joined.alignment.as_dict(), "dropped": joined.dropped,
         "rows_joined": len(joined.times_s)}, indent=1) + "\n")
    if plot:
        report.files["report_plot"] = "calibration_report.png"
        plot_report(data, out / "force.onnx", out / "calibration_report.png", report.split)
    return report


def write_joined(joined: Joined, path: Path) -> None:
    with atomic_output(path) as tmp, tmp.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["time_s", *[f"ch{i}" for i in range(CHANNELS)], "fx", "fy", "fz"])
        for t, c, f in zip(joined.times_s, joined.counts, joined.force, strict=True):
            w.writerow([f"{t:.6f}", *[f"{v:.0f}" for v in c], *[f"{v:.5f}" for v in f]])


def plot_report(data, model_path: Path, path: Path, split: str) -> Path:
    """Predicted against reference per axis (held-out rows marked), residuals over the
    run, and hysteresis loops (the strongest channel against the force along its face)."""
    from .runtime import ForceModel

    plt = pyplot()

    mode = split.split(":")[0] if split else "trial"
    _, te, _ = split_holdout(data, mode if mode in ("grid", "trial", "blocks") else "auto")
    held = np.zeros(len(data), bool)
    held[te] = True
    pred = ForceModel(model_path).estimate(data.counts.astype(np.float32))
    err = pred - data.force
    rmse = float(np.sqrt(np.mean(np.sum(err[held] ** 2, axis=1) / 2)))
    fig, ax = plt.subplots(2, 2, figsize=(11, 8))
    for j, name in enumerate(("Fx", "Fy")):
        a = ax[0, j]
        a.scatter(data.force[~held, j], pred[~held, j], s=2, alpha=0.3, label="training")
        a.scatter(data.force[held, j], pred[held, j], s=3, alpha=0.6, color="tab:red",
                  label="held out")
        lim = np.array([data.force[:, j].min(), data.force[:, j].max()])
        a.plot(lim, lim, "k--", lw=1)
        a.set_xlabel(f"reference {name} (N)")
        a.set_ylabel(f"predicted {name} (N)")
        a.set_title(f"{name}: held-out RMSE {np.sqrt(np.mean(err[held, j] ** 2)):.3f} N")
        a.legend(fontsize=8)
        a.grid(alpha=0.3)
    a = ax[1, 0]
    a.plot(np.arange(len(err)), err[:, 0], lw=0.6, label="Fx")
    a.plot(np.arange(len(err)), err[:, 1], lw=0.6, label="Fy")
    a.set_xlabel("joined row (recording order)")
    a.set_ylabel("predicted - reference (N)")
    a.set_title(f"residuals (held-out RMSE {rmse:.3f} N per axis)")
    a.legend(fontsize=8)
    a.grid(alpha=0.3)
    a = ax[1, 1]
    for ch in range(CHANNELS):
        ang = np.radians(ch * 90.0)
        along = data.force[:, 0] * np.cos(ang) + data.force[:, 1] * np.sin(ang)
        a.plot(along, data.counts[:, ch], lw=0.4, label=f"ch{ch}")
    a.set_xlabel("reference force along the channel's face normal (N)")
    a.set_ylabel("counts (tared)")
    a.set_title("hysteresis loops (loading and unloading)")
    a.legend(fontsize=8)
    a.grid(alpha=0.3)
    return save_png(fig, path, dpi=100)


__all__ = ["Alignment", "AlignmentError", "DatasetFormatError", "FingertipRecording",
           "align_and_join", "fit_joined", "load_fingertip_csv", "plot_report",
           "record_session", "trials_of"]
