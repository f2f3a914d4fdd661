"""The mains notch off and on, side by side in one process (same load): the vibration
bench's sets and protocols (:mod:`tests.bench.bench_vibration`), trained once per setting.

    PYTHONPATH=host:mechanical:. python tests/bench/compare_mains.py

Prints one JSON line per setting (and the load average), then both as a table. Needs the
drum kits of ``make drumkits`` for the real-hit rows (skipped, with a warning, without).
"""
from __future__ import annotations

import json
import logging
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from tests.bench import bench_vibration as bv  # noqa: E402
from tests.bench import public_sets as ps  # noqa: E402

SHIFTS = ("held-out (new slides)", "mains hum x3", "mains hum x10", "motor noise 1 rad/s")


def one(root: Path, notch: bool, real: bool) -> dict:
    """Accuracies (whole recording) with the notch ``notch``, on the sets under ``root``."""
    from fingertip.models.vibration.classify import load_folder
    from fingertip.models.vibration.material import train_material

    o: dict = {}
    t0 = time.perf_counter()
    for rate in (8000, 2200):
        r = train_material(bv._cut(load_folder(root / f"m{rate}"), 1.0),
                           root / f"r{rate}_{notch}", folds=5, seed=bv.SEED, plot=False,
                           mains_notch=notch).report
        o[f"first second, {rate} Hz"] = r["accuracy_by_time"]["whole"]["accuracy"]
    full = train_material(root / "m8000", root / f"full_{notch}", folds=5, seed=bv.SEED,
                          plot=False, mains_notch=notch)
    o["2 s slides, 8 kHz"] = full.report["accuracy_by_time"]["whole"]["accuracy"]
    kept = {k: bv.SHIFTS[k] for k in SHIFTS}
    saved = dict(bv.SHIFTS)
    bv.SHIFTS.clear()
    bv.SHIFTS.update(kept)
    try:
        shifts = bv.shift_accuracy(full.model_path, full.report["dataset"]["classes"])
    finally:
        bv.SHIFTS.clear()
        bv.SHIFTS.update(saved)
    o.update({k: v["whole"] for k, v in shifts.items()})
    if real:
        for name in ("knocks", "drums"):
            r = train_material(root / name, root / f"{name}_{notch}", folds=5, seed=bv.SEED,
                               plot=False, mains_notch=notch).report["accuracy_by_time"]
            o[f"real {name}"] = r["whole"]["accuracy"]
            o[f"real {name}, 0.25 s"] = r["0.25 s"]["accuracy"]
    o["seconds"] = round(time.perf_counter() - t0, 1)
    return o


def main() -> int:
    from fingertip.sim.dataset import write_vibration

    logging.basicConfig(level=logging.WARNING)
    out = {}
    with tempfile.TemporaryDirectory(prefix="compare_mains_") as tmp:
        root = Path(tmp)
        for rate in (8000, 2200):
            write_vibration(root / f"m{rate}", kind="materials",
                            recordings_per_class=bv.N_PER_CLASS, seconds=2.0, rate=rate,
                            seed=bv.SEED)
        base = ps.find_root(os.environ.get("FINGERTIP_DRUMKITS"))
        if base is None:
            logging.warning("hydrogen-drumkits not found (make drumkits): no real-hit rows")
        else:
            ps.knock_set(root / "knocks", base)
            ps.drum_set(root / "drums", base)
        for notch in (False, True):
            out[notch] = one(root, notch, base is not None)
            print(json.dumps({"mains_notch": notch, **out[notch],
                              "load_average": os.getloadavg()}), flush=True)
    print("| set | without | with the notch |\n|---|---|---|")
    for k in out[False]:
        fmt = (lambda v: f"{v:.1f} s") if k == "seconds" else (lambda v: f"{100 * v:.1f} %")
        print(f"| {k} | {fmt(out[False][k])} | {fmt(out[True][k])} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
