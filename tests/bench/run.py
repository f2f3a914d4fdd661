#!/usr/bin/env python3
"""Run the benchmarks and write docs/benchmarks.md and docs/benchmarks.json.

Each benchmark module has ``run() -> dict[str, number]`` and ``DESCRIPTION`` (key ->
(what it measures, target)), a target being ``None``, ``(op, value)`` with op one of
``>=``, ``<=``, ``<``, ``>``, or ``("within", (lo, hi))`` for a range (both ends
included, shown as ``lo-hi``). A missed target makes the run exit with status 1. Keys
from earlier runs that this run did not produce are kept, so a partial run
(``run.py decode``) updates only its own figures. ``run.py --render`` runs nothing: it
rewrites benchmarks.md from the json and meta files, each key's description, target and
status taken again from its bench module's ``DESCRIPTION`` (measured date and machine kept).
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
           "tasks", "reflex", "network", "realism", "check", "fuzz", "vibration", "hand",
           "robustness", "mujoco"]
OPTIONAL = ["soak"]
"""Run only when named (`make soak`): too long for a default run."""
JSON_OUT = ROOT / "docs" / "benchmarks.json"
MD_OUT = ROOT / "docs" / "benchmarks.md"


OPS = {">=": lambda a, b: a >= b, "<=": lambda a, b: a <= b,
       ">": lambda a, b: a > b, "<": lambda a, b: a < b,
       "within": lambda a, b: b[0] <= a <= b[1]}
HEADER_PREFIX = "Last run on: "
IDEAL_PREFIX = "ideal sensor"
"""A description starting so marks a figure of the ideal simulator (``Realism.ideal()``):
benchmarks.md lists those apart, after the realistic simulator's headline rows."""

Target = tuple[str, object] | None


def _num(v: float) -> str:
    # two decimals at least, so that a range reads "0.10-0.20" as the issues write it
    return f"{v:.2f}" if isinstance(v, float) and round(v, 2) == v else f"{v:,}"


def show_target(target: Target) -> str:
    """The target as the table shows it: ``<= 0.7`` or ``0.10-0.20``."""
    if target is None:
        return ""
    op, bound = target
    if op == "within":
        lo, hi = bound  # type: ignore[misc]
        return f"{_num(lo)}-{_num(hi)}"
    return f"{op} {bound:,}"


def check_target(key: str, target: Target) -> None:
    """Refuse a malformed target in a bench module's DESCRIPTION with one clear line."""
    if target is None:
        return
    op, bound = target
    if op not in OPS:
        raise SystemExit(f"{key}: unknown target operator {op!r} (one of {sorted(OPS)})")
    if op == "within" and not (isinstance(bound, tuple) and len(bound) == 2
                               and bound[0] <= bound[1]):
        raise SystemExit(f"{key}: a 'within' target needs (lo, hi) with lo <= hi, not "
                         f"{bound!r}")


def judge(value: float, target: Target) -> str:
    """``met``, ``MISSED`` or ``""`` (no target)."""
    if target is None:
        return ""
    return "met" if OPS[target[0]](value, target[1]) else "MISSED"


def _describe(mod, key: str) -> tuple[str, Target]:
    what, target = mod.DESCRIPTION.get(key, ("", None))
    check_target(key, target)
    return what, target


def _load(path: Path) -> dict:
    return json.loads(path.read_text()) if path.exists() else {}


def _rows(results: dict, meta: dict, keys: list[str]) -> list[str]:
    lines = ["| key | value | target | status | what | measured |", "|---|---|---|---|---|---|"]
    for key in keys:
        m = meta.get(key, {})
        v = results[key]
        shown = f"{v:,}" if isinstance(v, int) else f"{v:.4g}"
        lines.append(f"| `{key}` | {shown} | {m.get('target', '')} | {m.get('status', '')} | "
                     f"{m.get('what', '')} | "
                     f"{m.get('date', '')}, {m.get('machine', '')} |")
    return lines


def write_markdown(results: dict, meta: dict, tables: dict, header: str) -> None:
    lines = [
        "# Benchmarks",
        "",
        "Written by `make bench` (tests/bench/run.py); numbers in docs/benchmarks.json.",
        "Machines here are shared and noisy: each figure is the median of repeated runs, and",
        "comparisons are made between figures measured side by side in one run.",
        "",
        header,
        "",
    ]
    ideal = [k for k in sorted(results)
             if meta.get(k, {}).get("what", "").startswith(IDEAL_PREFIX)]
    lines += _rows(results, meta, [k for k in sorted(results) if k not in ideal])
    if ideal:
        lines += ["", "## Ideal sensor rows (the earlier simulator)", "",
                  "Measured on `Realism.ideal()` (the unit's spread and the HX711's white "
                  "noise only, none", "of the error budget's sources; docs/simulation.md): "
                  "kept for comparison, not headline figures.", ""]
        lines += _rows(results, meta, ideal)
    for title, table in sorted(tables.items()):
        lines += ["", f"## {title}", "", table.rstrip()]
    MD_OUT.write_text("\n".join(lines) + "\n")


def render() -> int:
    """Rewrite benchmarks.md (and the meta file's what/target/status) without running."""
    results = _load(JSON_OUT)
    meta = _load(MD_OUT.with_suffix(".meta.json"))
    tables = meta.pop("_tables", {})
    old = MD_OUT.read_text().splitlines() if MD_OUT.exists() else []
    header = next((ln for ln in old if ln.startswith(HEADER_PREFIX)), HEADER_PREFIX + "unknown")
    modules: dict[str, object] = {}
    missed = []
    for key, value in results.items():
        m = meta.get(key)
        if not m or not m.get("bench"):
            continue
        name = m["bench"]
        if name not in modules:
            modules[name] = importlib.import_module(f"tests.bench.bench_{name}")
        what, target = _describe(modules[name], key)
        m.update(what=what, target=show_target(target), status=judge(value, target))
        if m["status"] == "MISSED":
            missed.append(f"{key} = {value}, target {m['target']}")
    MD_OUT.with_suffix(".meta.json").write_text(
        json.dumps({**meta, "_tables": tables}, indent=1, sort_keys=True) + "\n")
    write_markdown(results, meta, tables, header)
    print(f"rendered {MD_OUT.relative_to(ROOT)} from {JSON_OUT.relative_to(ROOT)}")
    for m in missed:
        print(f"target missed: {m}", file=sys.stderr)
    return 1 if missed else 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", default=BENCHES,
                    help=f"subset of {BENCHES}; NAME:PART runs one part of a bench that has "
                         "PARTS (e.g. reflex:slip)")
    ap.add_argument("--render", action="store_true",
                    help="run nothing: rewrite benchmarks.md from the json and meta files")
    args = ap.parse_args()
    if args.render:
        if args.names != BENCHES:
            ap.error("--render takes no benchmark names")
        return render()
    unknown = {n.partition(":")[0] for n in args.names} - set(BENCHES) - set(OPTIONAL)
    if unknown:
        ap.error(f"unknown benchmarks: {sorted(unknown)}")
    results = _load(JSON_OUT)
    meta = _load(MD_OUT.with_suffix(".meta.json"))
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
            what, target = _describe(mod, key)
            status = judge(value, target)
            if status == "MISSED":
                missed.append(f"{key} = {value}, target {show_target(target)}")
            meta[key] = {"bench": name, "what": what, "target": show_target(target),
                         "status": status, "machine": machine["cpu"],
                         "date": machine["date"]}
        results.update(figures)
    JSON_OUT.write_text(json.dumps(dict(sorted(results.items())), indent=1) + "\n")
    MD_OUT.with_suffix(".meta.json").write_text(
        json.dumps({**meta, "_tables": tables}, indent=1, sort_keys=True) + "\n")
    write_markdown(results, meta, tables,
                   HEADER_PREFIX + ", ".join(f"{k} {v}" for k, v in machine.items()))
    print(f"wrote {MD_OUT.relative_to(ROOT)} and {JSON_OUT.relative_to(ROOT)}")
    for m in missed:
        print(f"target missed: {m}", file=sys.stderr)
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main())
