"""The paper's methods against ours on the realistic virtual fingertip, side by side.

Force: virtual units 1-3 with every documented error source (fingertip.sim.physics.realism),
each one session of the paper's protocol (66 trials x 40 readings, 8 s pauses), tared; a
random 80/20 split of the readings; the paper's MLP (fingertip.sim.paper_method) and ours
(``fingertip calibrate fit``: fit_calibration with its default models and own choice) on the
same training rows, scored on the same test rows. Also: whole trials held out instead, the
ideal sensor (``Realism.ideal()``: unit spread and white noise only, the simulator the
project's earlier figures came from), and the ablation (every source
on but one) for docs/simulation.md's error budget. ``ablation_only()`` (each source alone)
is not part of the bench run: it doubles its cost; docs/simulation.md quotes one run of it.

Material: the paper's seven materials, 100 simulated slides each; the paper's STFT + MLP on
a random split of its windows against ours (train_material, 5-fold cross-validation by
recording) on the same slides. Shake: the same STFT + MLP on the paper's shake protocol (20
shakes per class); ours is bench_classify's ``shake_window_accuracy_*``.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from fingertip.sim.paper_method import (
    PAPER_FORCE_MSE_N2,
    PAPER_MATERIAL_ACCURACY,
    compare_force,
    paper_vibration,
    read_folder,
)
from fingertip.sim.physics import Realism

UNITS = (1, 2, 3)
SEED = 0


def _pin() -> None:
    try:
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    except (AttributeError, OSError):
        pass


def _mean_mse(realism: Realism, *, ours: bool = False, split: str = "rows"):
    runs = [compare_force(u, realism, ours=ours, seed=SEED, split=split) for u in UNITS]
    paper = float(np.mean([r.paper_mse_n2 for r in runs]))
    mine = float(np.mean([r.ours_mse_n2 for r in runs])) if ours else float("nan")
    return paper, mine


def _force() -> dict[str, float]:
    out: dict[str, float] = {}
    paper, ours = _mean_mse(Realism(), ours=True)
    out["sim_paper_method_force_mse_n2"] = round(paper, 4)
    out["sim_ours_force_mse_n2"] = round(ours, 4)
    out["force_rmse_ratio_vs_paper_method"] = round(float(np.sqrt(ours / paper)), 4)
    out["sim_paper_method_force_mse_n2_trial_split"] = round(
        _mean_mse(Realism(), split="trials")[0], 4)
    ideal_p, ideal_o = _mean_mse(Realism.ideal(), ours=True)
    out["ideal_sensor_paper_method_force_mse_n2"] = round(ideal_p, 4)
    out["ideal_sensor_ours_force_mse_n2"] = round(ideal_o, 4)
    for name in Realism.sources():
        out[f"ablation_force_mse_without_{name}"] = round(
            _mean_mse(Realism().without(name))[0], 4)
    return out


def ablation_only() -> dict[str, float]:
    """The paper's force method with each source alone (not run by the bench)."""
    return {f"ablation_force_mse_only_{n}": round(_mean_mse(Realism().only(n))[0], 4)
            for n in Realism.sources()}


def _material() -> dict[str, float]:
    from fingertip.models.classify import load_folder
    from fingertip.models.material import train_material
    from fingertip.sim.dataset import write_vibration

    with tempfile.TemporaryDirectory(prefix="bench_realism_") as tmp:
        root = Path(tmp)
        write_vibration(root / "materials", kind="materials", recordings_per_class=100,
                        seed=SEED, progress=False)
        xs, ys, classes = read_folder(root / "materials")
        paper = paper_vibration(xs, ys, classes, split="windows", seed=SEED)
        by_rec = paper_vibration(xs, ys, classes, split="recordings", seed=SEED)
        ours = train_material(load_folder(root / "materials"), root / "model", folds=5,
                              seed=SEED, plot=False).evaluation.windows.accuracy
        write_vibration(root / "shake", kind="shake", recordings_per_class=20, seed=SEED,
                        progress=False)
        shake = paper_vibration(*read_folder(root / "shake"), split="windows", seed=SEED)
    return {"sim_paper_method_material_accuracy": round(paper.accuracy, 4),
            "sim_paper_method_material_accuracy_by_recording": round(by_rec.accuracy, 4),
            "sim_ours_material_accuracy": round(float(ours), 4),
            "material_accuracy_minus_paper_method": round(float(ours) - paper.accuracy, 4),
            "sim_paper_method_shake_window_accuracy": round(shake.accuracy, 4)}


def run() -> dict[str, float]:
    _pin()
    out = _force()
    out.update(_material())
    return out


DESCRIPTION = {
    "sim_paper_method_force_mse_n2": (
        "the paper's force method (66 trials x 40 readings, MLP 64x64, random 80/20 split of "
        f"readings) on realistic virtual units 1-3, mean MSE (N^2; paper {PAPER_FORCE_MSE_N2}, "
        "goal 0.10-0.20)", (">=", 0.10)),
    "sim_ours_force_mse_n2": ("ours (fingertip calibrate fit) on the same rows, mean MSE (N^2)",
                              None),
    "force_rmse_ratio_vs_paper_method": ("our force RMSE over the paper method's, same units, "
                                         "same test rows", ("<=", 0.7)),
    "sim_paper_method_force_mse_n2_trial_split": (
        "paper's method with whole trials held out instead of random readings (N^2)", None),
    "ideal_sensor_paper_method_force_mse_n2": (
        "ideal sensor (unit spread and HX711 white noise only: the earlier simulator): "
        "paper's method (N^2)", None),
    "ideal_sensor_ours_force_mse_n2": ("ideal sensor: ours (N^2)", None),
    "sim_paper_method_material_accuracy": (
        "the paper's material method (STFT, 86-frame windows, MLP, random split of windows) on "
        f"7 x 100 simulated slides (paper {PAPER_MATERIAL_ACCURACY}, goal 0.93-0.98)",
        (">=", 0.93)),
    "sim_paper_method_material_accuracy_by_recording": (
        "same with whole slides held out (no overlapping window on both sides)", None),
    "sim_ours_material_accuracy": ("ours (train_material, 5-fold by recording), same slides, "
                                   "per window", None),
    "material_accuracy_minus_paper_method": ("our material accuracy minus the paper method's, "
                                             "same slides", (">=", 0.0)),
    "sim_paper_method_shake_window_accuracy": (
        "the paper's STFT + MLP on 3 x 20 simulated shakes (screws, rubber bands, empty), "
        "random split of windows, per window (the paper's 94.64 % is its task success)", None),
}
for _n in Realism.sources():
    DESCRIPTION[f"ablation_force_mse_without_{_n}"] = (
        f"paper's force method, every error source but {_n} (N^2)", None)


def tables(r: dict[str, float]) -> dict[str, str]:
    """The error budget: what each source adds to the paper method's calibration error."""
    allp = r.get("sim_paper_method_force_mse_n2")
    none = r.get("ideal_sensor_paper_method_force_mse_n2")
    if allp is None or none is None:
        return {}
    rows = ["| source | MSE without it (N^2) | all minus without |", "|---|---|---|"]
    for n in Realism.sources():
        w = r.get(f"ablation_force_mse_without_{n}")
        if w is not None:
            rows.append(f"| {n} | {w:.4f} | {allp - w:+.4f} |")
    rows.append(f"| (all sources) | {allp:.4f} | |")
    rows.append(f"| (ideal sensor) | {none:.4f} | |")
    return {"Realistic simulator: error budget of the paper's force method": "\n".join(rows)}


if __name__ == "__main__":  # each source alone, for docs/simulation.md (not run by the bench)
    for key, value in ablation_only().items():
        print(f"{key} = {value}")
