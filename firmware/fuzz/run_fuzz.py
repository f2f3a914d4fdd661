"""Run the libFuzzer targets for a while each and sum up what they did.

    python3 run_fuzz.py BUILD_DIR SECONDS_PER_TARGET [TARGET ...]

For each target, BUILD_DIR/fuzz_<target> runs on its corpus BUILD_DIR/corpus/<target>
(seeded, and grown by earlier runs) with -max_total_time; a crash input is kept in
BUILD_DIR/crashes/<target>/. Writes BUILD_DIR/stats.json ({"targets": {name: {"execs",
"crashes", "seconds"}}, "execs", "crashes"}), prints one line per target, and exits 1 if
any target crashed (or did not run). The targets run side by side, one per core (each still
gets its SECONDS of a core to itself on a machine with a core per target; one at a time
where there are fewer cores). Standard library only: it runs before any venv exists.
"""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

TARGETS = ("cobs", "receiver")


def run_target(build: Path, name: str, seconds: int) -> dict:
    binary = build / f"fuzz_{name}"
    corpus = build / "corpus" / name
    crashes = build / "crashes" / name
    crashes.mkdir(parents=True, exist_ok=True)
    t0 = time.monotonic()
    p = subprocess.run(
        [str(binary), f"-max_total_time={seconds}", "-print_final_stats=1",
         "-timeout=10", "-rss_limit_mb=1024", f"-artifact_prefix={crashes}/", str(corpus)],
        capture_output=True, text=True, timeout=seconds + 120)
    dt = time.monotonic() - t0
    m = re.findall(r"stat::number_of_executed_units:\s*(\d+)", p.stderr)
    execs = int(m[-1]) if m else 0
    crashed = p.returncode != 0 or "ERROR: libFuzzer" in p.stderr or \
        "ERROR: AddressSanitizer" in p.stderr or "runtime error:" in p.stderr
    if crashed:
        tail = "\n".join(p.stderr.splitlines()[-25:])
        print(f"fuzz {name}: CRASH (exit {p.returncode})\n{tail}", file=sys.stderr)
    return {"execs": execs, "crashes": int(crashed), "seconds": round(dt, 1),
            "corpus": len(list(corpus.iterdir())) if corpus.is_dir() else 0}


def main(argv: list[str]) -> int:
    if len(argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    build, seconds = Path(argv[0]), int(argv[1])
    names = argv[2:] or list(TARGETS)
    with ThreadPoolExecutor(max_workers=min(len(names), os.cpu_count() or 1)) as pool:
        runs = [pool.submit(run_target, build, n, seconds) for n in names]
        stats = {n: r.result() for n, r in zip(names, runs, strict=True)}
    total = {"targets": stats, "execs": sum(s["execs"] for s in stats.values()),
             "crashes": sum(s["crashes"] for s in stats.values())}
    (build / "stats.json").write_text(json.dumps(total, indent=1) + "\n")
    for n, s in stats.items():
        print(f"fuzz {n}: {s['execs']} executions in {s['seconds']} s, corpus {s['corpus']}, "
              f"{'CRASHED' if s['crashes'] else 'no crash'}")
    bad = total["crashes"] or any(s["execs"] == 0 for s in stats.values())
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
