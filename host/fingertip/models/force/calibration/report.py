"""The calibration report: per-model results, the choice, JSON, Markdown and the figure, and
the metadata written into each ONNX file."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ....protocol import INT24_MAX, INT24_MIN
from ...nets.figures import pyplot, save_png
from .data import CalibrationData
from .evaluate import rmse
from .limits import CHANNELS


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

    def fit_text(self, out_dir: str | Path) -> str:
        """What ``calibrate fit`` prints: what was held out, the table, the chosen model
        and its rule, the files written into ``out_dir``."""
        c = self.chosen_result
        return (f"held out: {self.split}\n"
                f"{self.rows_train} training rows, {self.rows_test} test rows\n\n"
                f"{self.table()}\n\n"
                f"chosen: {c.name} (held-out RMSE {c.rmse_n:.3f} N, MSE {c.mse_n2:.4f} N^2, "
                f"{c.latency_us_single:.1f} us per frame)\n{self.rule}\n"
                f"wrote {out_dir}: force.onnx (= force_{c.name}.onnx), force_<model>.onnx "
                f"for each model, {self.files_text()}")

    def files_text(self, extra: tuple[str, ...] = ()) -> str:
        """The report's files (and ``extra`` ones written beside them), comma-separated."""
        return ", ".join([v for k, v in self.files.items() if k != "chosen"] + list(extra))

    def chosen_text(self, out_dir: str | Path, extra: tuple[str, ...] = (),
                    how: str = "") -> str:
        """The models' table and the line naming the chosen model and the files written
        (``extra``: more files written beside the report's; ``how``: how the held-out rows
        were chosen, when not by trial)."""
        c = self.chosen_result
        return (f"{self.table()}\n\nchosen: {c.name} (held-out RMSE {c.rmse_n:.3f} N{how}); "
                f"wrote {out_dir}: force.onnx, {self.files_text(extra)}")

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


def _plot(report: CalibrationReport, path: Path) -> Path:
    plt = pyplot()

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
    return save_png(fig, path, dpi=110)


def model_metadata(model, data: CalibrationData, train: CalibrationData, *,
                   heldout: dict[str, float] | None = None, split: str = "") -> dict[str, Any]:
    """The ONNX metadata :class:`~fingertip.models.force.runtime.ForceModel` reads."""
    from .... import __version__

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
