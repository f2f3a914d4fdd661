"""Calibration datasets: the paper's sweep on virtual units as CSV, in the layout of
``fingertip export`` plus the sweep's ground truth, and the reader of those files."""
from __future__ import annotations

import csv
import math
import os
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ... import __version__
from ...protocol.messages import INT24_MAX, INT24_MIN
from ..physics import VirtualStrainSensor
from ..device.calibration_rig import calibration_sweep
from .output import (
    GENERATOR,
    DatasetError,
    DatasetResult,
    Progress,
    check_int,
    derived_seed,
    load_params_file,
    write_meta,
    params_sha256,
    prepare_output,
)

CALIBRATION_COLUMNS: dict[str, str] = {
    "unix_time": "seconds; simulated: device time since the session start (no wall clock, "
                 "so that files are reproducible)",
    "host_time": "seconds; simulated: equal to unix_time (a host clock locked to the device)",
    "device_time_us": "the conversion's device timestamp, microseconds (int)",
    "seq": "the conversion's number since boot (device time / period), modulo 2^16; only "
           "the readings at the end of each pause are written, so it jumps between rows",
    "arrival_time": "seconds; simulated: equal to host_time",
    "ch0": "HX711 counts of the +x gauge at gain 128, as streamed (after the tare)",
    "ch1": "same, +y gauge",
    "ch2": "same, -x gauge",
    "ch3": "same, -y gauge",
    "timeout_mask": "bit i set: chip i did not answer (always 0 here)",
    "saturation_mask": "bit i set: channel i at the ADC's limit (-2^23 or 2^23-1)",
    "fx": "true force on the fingertip along x, N (in a real session: the F/T sensor)",
    "fy": "true force along y, N",
    "fz": "true axial force, N (0 in this sweep)",
    "angle_deg": "indentation direction in the XY plane, degrees (-50..50)",
    "height_mm": "contact height below the nail tip, mm (0..5)",
    "displacement_mm": "indenter travel from its start position, mm (steps of 1.5 mm)",
    "phase": "loading (travel increasing) or unloading (retracting)",
    "trial": "trial number within the sweep (angles and heights in random order)",
    "step": "step number within the trial",
    "sweep": "sweep number for this unit (0..sweeps-1)",
    "unit_seed": "which virtual fingertip (its per-unit variation)",
}


def write_calibration(out: str | os.PathLike, *, units: int = 1, seed: int = 0,
                      sweeps: int = 1, rate_sps: int = 80, samples_per_step: int = 1,
                      tare_samples: int = 16, max_force_n: float = 5.0,
                      params_file: str | os.PathLike | None = None, force: bool = False,
                      progress: bool = False) -> DatasetResult:
    """The paper's calibration sweep on units ``seed .. seed + units - 1``: one CSV per unit
    (``unit_<seed>.csv``, columns :data:`CALIBRATION_COLUMNS`) and ``dataset.json``.

    Each unit is tared first with ``tare_samples`` readings at zero load (as ``fingertip
    tare`` does on the device; 0: raw counts with their offsets of a few 1e5), then swept
    ``sweeps`` times in a row (one continuous history: hysteresis and creep carry over;
    each sweep draws its own trial order and contact points).
    """
    units = check_int("units", units, 1, 10_000)
    seed = check_int("seed", seed, 0, 2 ** 31 - 1 - units)
    sweeps = check_int("sweeps", sweeps, 1, 100)
    samples_per_step = check_int("samples per step", samples_per_step, 1, 64)
    tare_samples = check_int("tare samples", tare_samples, 0, 256)
    if rate_sps not in (10, 80):
        raise DatasetError(f"rate must be 10 or 80 SPS (the HX711's RATE pin), not {rate_sps}")
    if not (isinstance(max_force_n, (int, float)) and 0 < max_force_n <= 50):
        raise DatasetError(f"max force must be in (0, 50] N, not {max_force_n!r}")
    params, pfile = load_params_file(params_file)
    out = Path(out)
    w0 = time.monotonic()
    warnings = prepare_output(out, force)
    unit_seeds = [seed + i for i in range(units)]
    files = [f"unit_{s}.csv" for s in unit_seeds]
    period_us = 1_000_000 // rate_sps
    meta: dict[str, Any] = {
        "generator": GENERATOR, "kind": "calibration", "fingertip_version": __version__,
        "complete": False, "seed": seed, "units": unit_seeds, "sweeps_per_unit": sweeps,
        "rate_sps": rate_sps, "gain": 128, "channels": 4, "format": "csv",
        "params_file": pfile or "fingertip/hardware/fingertip.toml (shipped)",
        "params_sha256": params_sha256(params_file),
        "protocol": {"angles_deg": list(range(-50, 51, 10)), "heights_mm": [0, 1, 2, 3, 4, 5],
                     "step_mm": 1.5, "travel_mm": 30.0, "pause_s": 8.0, "move_s": 0.5,
                     "rest_s": 5.0, "samples_per_step": samples_per_step,
                     "max_force_n": float(max_force_n), "randomized": True},
        "tare_samples": tare_samples, "tare_offsets": {}, "rows": {},
        "columns": CALIBRATION_COLUMNS, "files": files,
    }
    try:
        write_meta(out, meta)
        bar = Progress(units * sweeps, f"calibration {out}", enabled=progress)
        for unit, name in zip(unit_seeds, files, strict=True):
            sensor = VirtualStrainSensor(unit, params=params, rate_sps=rate_sps)
            offsets = [0, 0, 0, 0]
            t_next_us = 0
            if tare_samples:
                t = period_us * (1 + np.arange(tare_samples, dtype=np.int64))
                raw = sensor.counts_batch(np.zeros((tare_samples, 2)), 0.0, t * 1e-6)
                s = raw.sum(axis=0)
                n = tare_samples
                offsets = [int((abs(int(v)) + n // 2) // n * (1 if v >= 0 else -1)) for v in s]
                t_next_us = int(t[-1])
            rows = 0
            with open(out / name, "w", newline="", encoding="utf-8") as f:
                w = csv.writer(f, lineterminator="\n")
                w.writerow(CALIBRATION_COLUMNS)
                for k in range(sweeps):
                    sw = calibration_sweep(
                        sensor, seed=derived_seed(seed, unit, k, 0xCA1),
                        samples_per_step=samples_per_step, max_force_n=float(max_force_n),
                        t0_us=t_next_us + 1_000_000)
                    _write_sweep_rows(w, sw, offsets, period_us, k, unit)
                    rows += len(sw)
                    t_next_us = int(sw.t_us[-1])
                    bar.step(f"{name} sweep {k}")
            meta["tare_offsets"][name] = offsets
            meta["rows"][name] = rows
        meta["complete"] = True
        write_meta(out, meta)
    except OSError as e:
        raise DatasetError(f"writing into {out} failed: {e.strerror or e}", 1) from e
    return DatasetResult(out, [Path(n) for n in files], meta, warnings, time.monotonic() - w0)


def _write_sweep_rows(w, sw, offsets: Sequence[int], period_us: int, sweep: int,
                      unit: int) -> None:
    counts = np.clip(sw.counts - np.asarray(offsets, dtype=np.int64), INT24_MIN, INT24_MAX)
    sat = (sw.counts <= INT24_MIN) | (sw.counts >= INT24_MAX) \
        | (sw.counts - np.asarray(offsets) < INT24_MIN) \
        | (sw.counts - np.asarray(offsets) > INT24_MAX)
    smask = (sat * (1 << np.arange(4))).sum(axis=1)
    for i in range(len(sw)):
        t_us = int(sw.t_us[i])
        t_s = f"{t_us / 1e6:.6f}"
        c = counts[i]
        w.writerow([t_s, t_s, t_us, (t_us // period_us) & 0xFFFF, t_s,
                    int(c[0]), int(c[1]), int(c[2]), int(c[3]), 0, int(smask[i]),
                    repr(float(sw.fx[i])), repr(float(sw.fy[i])), "0.0",
                    repr(float(sw.angle_deg[i])), repr(float(sw.height_mm[i])),
                    repr(float(sw.displacement_mm[i])),
                    "loading" if sw.loading[i] else "unloading",
                    int(sw.trial[i]), int(sw.step[i]), sweep, unit])


def read_calibration_csv(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """A calibration CSV as columns: numbers as int64/float64 arrays, ``phase`` as strings.
    Reads any CSV with a header (a real session's export with reference forces too)."""
    with open(path, newline="", encoding="utf-8") as f:
        r = csv.reader(f)
        try:
            head = next(r)
        except StopIteration:
            raise DatasetError(f"{path} is empty") from None
        cols: list[list[str]] = [[] for _ in head]
        for row in r:
            for c, v in zip(cols, row, strict=False):
                c.append(v)
    out: dict[str, np.ndarray] = {}
    for name, values in zip(head, cols, strict=True):
        out[name] = _column(values)
    return out


def _column(values: list[str]) -> np.ndarray:
    try:
        return np.array(values, dtype=np.int64)
    except ValueError:
        pass
    try:
        return np.array([float(v) if v != "" else math.nan for v in values])
    except ValueError:
        return np.array(values, dtype=str)
