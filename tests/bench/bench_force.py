"""Force calibration: held-out error and onnxruntime latency of each model type.

Ideal sensor (``Realism.ideal()``: the unit's spread and the HX711's white noise, none of the
error budget's sources; bench_realism has the realistic figures): virtual unit 1, tared, then
three consecutive sweeps of the paper's
protocol (angles -50..50 deg, heights 0..5 mm, 1.5 mm steps to 30 mm and back). The first
two sweeps (5280 rows) go to ``fit_calibration`` with its defaults: whole (angle, height)
cells held out (a quarter, both sweeps of a cell on the test side), every model exported to
ONNX and timed with onnxruntime on one thread (one frame: median of 2000 calls; batch of
1000: median of 30 calls, per frame). The chosen model is also run through ``ForceModel``
on the third sweep, a later session it never saw. Errors are vector RMSE over (Fx, Fy).
"""
from __future__ import annotations

import os
import statistics
import tempfile
import time

import numpy as np

from fingertip.models.force.calibrate import DEFAULT_MODELS, fit_calibration, from_arrays, rmse
from fingertip.models.force.runtime import ForceModel
from fingertip.sim.physics import Realism, VirtualStrainSensor
from fingertip.sim.device.calibration_rig import calibration_sweep

UNIT = 1


def _sweeps(unit: int, n: int):
    sensor = VirtualStrainSensor(unit, realism=Realism.ideal())
    tare = np.rint(sensor.counts_batch(np.zeros((16, 2)), 0.0, np.arange(1, 17) / 80)
                   .mean(axis=0))
    out, t0 = [], 1_000_000
    for k in range(n):
        sw = calibration_sweep(sensor, seed=1000 * unit + k, t0_us=t0)
        t0 = int(sw.t_us[-1]) + 1_000_000
        out.append(sw)
    return out, tare


def run() -> dict[str, float]:
    try:
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    except (AttributeError, OSError):
        pass
    sweeps, tare = _sweeps(UNIT, 3)
    fit = sweeps[:2]

    def cat(attr):
        return np.concatenate([getattr(s, attr) for s in fit])

    data = from_arrays(cat("counts") - tare, cat("fx"), cat("fy"), angle_deg=cat("angle_deg"),
                       height_mm=cat("height_mm"),
                       trial=np.concatenate([s.trial + 1000 * k for k, s in enumerate(fit)]),
                       phase=np.where(cat("loading"), "loading", "unloading"))
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        rep = fit_calibration(data, tmp, models=DEFAULT_MODELS, plot=False)
        fit_s = time.perf_counter() - t0
        fm = ForceModel(os.path.join(tmp, "force.onnx"))
        later = sweeps[2]
        later_rmse = rmse(fm.estimate(later.counts - tare),
                          np.column_stack([later.fx, later.fy]))
        frame = [int(v) for v in (later.counts[len(later) // 2] - tare)]
        for _ in range(200):
            fm.estimate(frame)
        t = []
        for _ in range(3000):
            a = time.perf_counter_ns()
            fm.estimate(frame)
            t.append(time.perf_counter_ns() - a)
    c = rep.chosen_result
    out: dict[str, float] = {
        "force_rmse_n": round(c.rmse_n, 4),
        "force_mse_n2": round(c.mse_n2, 5),
        "force_rmse_later_sweep_n": round(later_rmse, 4),
        "force_latency_us": round(statistics.median(t) / 1e3, 2),
        "force_chosen_index": list(DEFAULT_MODELS).index(rep.chosen),
        "force_float32_err_max_n": max(m.float32_err_n for m in rep.models),
        "force_fit_s": round(fit_s, 2),
    }
    for m in rep.models:
        out[f"force_rmse_{m.name}"] = round(m.rmse_n, 4)
        out[f"force_latency_us_single_{m.name}"] = round(m.latency_us_single, 2)
        out[f"force_latency_us_batch_{m.name}"] = round(m.latency_us_batch, 4)
    return out


_MODELS = ", ".join(f"{i} {n}" for i, n in enumerate(DEFAULT_MODELS))

DESCRIPTION = {
    "force_rmse_n": ("ideal sensor: force RMSE (N) of the chosen model on held-out (angle, "
                     "height) cells, virtual unit 1, 0-5 N (paper: MSE 0.15 N^2, about 0.39 N)",
                     ("<=", 0.2)),
    "force_mse_n2": ("ideal sensor: same as MSE (N^2, vector)", ("<=", 0.15)),
    "force_rmse_later_sweep_n": ("ideal sensor: chosen model through ForceModel on a later "
                                 "sweep of the "
                                 "same unit, never seen (N)", ("<=", 0.2)),
    "force_latency_us": ("ForceModel.estimate, chosen model, one frame, p50 (us)",
                         ("<", 100)),
    "force_chosen_index": (f"chosen model: fastest within 10 % of the best RMSE ({_MODELS})",
                           None),
    "force_float32_err_max_n": ("largest float32 (ONNX) minus float64 difference over the "
                                "models, held-out rows (N)", ("<", 2e-4)),
    "force_fit_s": ("wall time of fit_calibration with all six models (s)", None),
}
for _n in DEFAULT_MODELS:
    DESCRIPTION[f"force_rmse_{_n}"] = (f"ideal sensor, {_n}: held-out RMSE (N), same split",
                                      None)
    DESCRIPTION[f"force_latency_us_single_{_n}"] = (
        f"{_n}: onnxruntime, one frame per call, p50 (us)", None)
    DESCRIPTION[f"force_latency_us_batch_{_n}"] = (
        f"{_n}: onnxruntime, batch of 1000, per frame, p50 (us)", None)


def tables(r: dict[str, float]) -> dict[str, str]:
    """The speed-against-error table of the force models, from one run's figures."""
    models = sorted({k[len("force_rmse_"):] for k in r if k.startswith("force_rmse_")
                     and not k.endswith("_n")}, key=lambda m: r[f"force_rmse_{m}"])
    rows = ["| model | held-out RMSE (N) | one frame (us, p50) | per frame in a batch of "
            "1000 (us) |", "|---|---|---|---|"]
    for m in models:
        rows.append(f"| {m} | {r[f'force_rmse_{m}']:.3f} | "
                    f"{r.get(f'force_latency_us_single_{m}', float('nan')):.2f} | "
                    f"{r.get(f'force_latency_us_batch_{m}', float('nan')):.3f} |")
    return {"Force models: speed against error": "\n".join(rows)}
