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
   degree 2-3) and MLPs (:func:`~fingertip.models.nets.mlp.train_mlp`), all on standardised
   inputs;
4. exports each to ONNX (float32, normalisation inside the graph), measures its latency with
   onnxruntime and its float32 error against the float64 reference, and picks the fastest
   model whose held-out RMSE is within ``bound_pct`` of the best (:func:`fit_calibration`).

Errors are vector errors: RMSE = sqrt(mean |F_est - F_true|^2) in N, MSE = its square in
N^2 (the per-component MSE is half of it). Training needs numpy and ``onnx``; the runtime
(:mod:`fingertip.models.force.runtime`) only numpy and onnxruntime.
"""
from __future__ import annotations

import json
import math
import os
import shutil
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ...outputs import write_text
from ...protocol import INT24_MAX, INT24_MIN
from .calibration.checks import check_dataset, describe, design_condition
from .calibration.data import CalibrationData, from_arrays, load_dataset
from .calibration.errors import (
    CalibrationError,
    DatasetFormatError,
    DeadChannelError,
    IllConditionedError,
    MixedUnitsError,
    NonFiniteError,
    SaturationError,
    SingleDirectionError,
    TooFewRowsError,
)
from .calibration.evaluate import (_by, angle_keys, extreme_inputs, float32_error,
                                   measure_latency, rmse)
from .calibration.limits import CHANNELS, MAX_CONDITION, MAX_SATURATED_FRACTION, Progress
from .calibration.maps import (DEFAULT_MODELS, expand_models, fit_affine, fit_mlp, fit_model,
                               fit_poly)
from .calibration.report import CalibrationReport, ModelResult, _plot, model_metadata
from .calibration.select import choose
from .calibration.split import split_groups, split_holdout

__all__ = [
    "CHANNELS", "CalibrationData", "CalibrationError", "CalibrationReport", "DEFAULT_MODELS",
    "DatasetFormatError", "DeadChannelError", "INT24_MAX", "INT24_MIN", "IllConditionedError",
    "MAX_CONDITION", "MAX_SATURATED_FRACTION", "MixedUnitsError", "ModelResult",
    "NonFiniteError", "Progress", "SaturationError", "SingleDirectionError", "TooFewRowsError",
    "angle_keys", "check_dataset", "choose", "describe", "design_condition", "expand_models",
    "extreme_inputs", "fit_affine", "fit_calibration", "fit_mlp", "fit_model", "fit_poly",
    "float32_error", "from_arrays", "load_dataset", "measure_latency", "model_metadata",
    "rmse", "split_groups", "split_holdout"
]


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
    write_text(out / files["json"], json.dumps(report.as_dict(), indent=1) + "\n")
    write_text(out / files["markdown"], report.markdown())
    return report
