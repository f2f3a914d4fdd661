#!/usr/bin/env python3
"""Run the benchmarks and write docs/benchmarks.md and docs/benchmarks.json.

Each benchmark module has ``run() -> dict[str, number]`` and ``DESCRIPTION`` (key ->
(what it measures, target)), a target being ``None`` or ``(op, value)`` with op one of
``>=``, ``<=``, ``<``, ``>``. A missed target makes the run exit with status 1. Keys
from earlier runs that this run did not produce are kept, so a partial run
(``run.py decode``) updates only its own figures.
"""
from __future__ import annotations

import argparse
import importlib
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from tests.bench.machine import describe  # noqa: E402

BENCHES = ["decode", "firmware", "bridge", "align", "sim", "force", "classify", "events",
           "tasks", "reflex", "network", "realism", "check", "fuzz", "vibration", "hand"]
OPTIONAL = ["soak"]
"""Run only when named (`make soak`): too long for a default run."""
JSON_OUT = ROOT / "docs" / "benchmarks.json"
MD_OUT = ROOT / "docs" / "benchmarks.md"


OPS = {">=": lambda a, b: a >= b, "<=": lambda a, b: a <= b,
       ">": lambda a, b: a > b, "<": lambda a, b: a < b}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", default=BENCHES,
                    help=f"subset of {BENCHES}; NAME:PART runs one part of a bench that has "
                         "PARTS (e.g. reflex:slip)")
    args = ap.parse_args()
    unknown = {n.partition(":")[0] for n in args.names} - set(BENCHES) - set(OPTIONAL)
    if unknown:
        ap.error(f"unknown benchmarks: {sorted(unknown)}")
    results = json.loads(JSON_OUT.read_text()) if JSON_OUT.exists() else {}
    meta = json.loads(MD_OUT.with_suffix(".meta.json").read_text()) \
        if MD_OUT.with_suffix(".meta.json").exists() else {}
    machine = describe()
    missed = []
    tables = meta.pop("_tables", {})
    for arg in args.names:
        name, _, part = arg.partition(":")
        mod = importlib.import_module(f"tests.bench.bench_{name}")
        parts = getattr(mod, "PARTS", {})
        if part and part not in parts:
            ap.error(f"bench {name} has no part {part!r} (parts: {sorted(parts)})")
        print(f"bench {arg} ...", flush=True)
        figures = parts[part]() if part else mod.run()
        if hasattr(mod, "tables"):  # markdown tables made from this run's figures
            tables.update(mod.tables(figures))
        for key, value in figures.items():
            print(f"  {key} = {value}")
            what, target = mod.DESCRIPTION.get(key, ("", None))
            status = ""
            if target is not None:
                status = "met" if OPS[target[0]](value, target[1]) else "MISSED"
                if status == "MISSED":
                    missed.append(f"{key} = {value}, target {target[0]} {target[1]}")
            meta[key] = {"bench": name, "what": what,
                         "target": f"{target[0]} {target[1]:,}" if target else "",
                         "status": status, "machine": machine["cpu"],
                         "date": machine["date"]}
        results.update(figures)
    JSON_OUT.write_text(json.dumps(dict(sorted(results.items())), indent=1) + "\n")
    MD_OUT.with_suffix(".meta.json").write_text(
        json.dumps({**meta, "_tables": tables}, indent=1, sort_keys=True) + "\n")
    lines = [
        "# Benchmarks",
        "",
        "Written by `make bench` (tests/bench/run.py); numbers in docs/benchmarks.json.",
        "Machines here are shared and noisy: each figure is the median of repeated runs, and",
        "comparisons are made between figures measured side by side in one run.",
        "",
        "Last run on: " + ", ".join(f"{k} {v}" for k, v in machine.items()),
        "",
        "| key | value | target | status | what | measured |",
        "|---|---|---|---|---|---|",
    ]
    for key in sorted(results):
        m = meta.get(key, {})
        v = results[key]
        shown = f"{v:,}" if isinstance(v, int) else f"{v:.4g}"
        lines.append(f"| `{key}` | {shown} | {m.get('target', '')} | {m.get('status', '')} | "
                     f"{m.get('what', '')} | "
                     f"{m.get('date', '')}, {m.get('machine', '')} |")
    for title, table in sorted(tables.items()):
        lines += ["", f"## {title}", "", table.rstrip()]
    MD_OUT.write_text("\n".join(lines) + "\n")
    print(f"wrote {MD_OUT.relative_to(ROOT)} and {JSON_OUT.relative_to(ROOT)}")
    for m in missed:
        print(f"target missed: {m}", file=sys.stderr)
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main())
