"""Bad inputs and faults (issue 28): the table of tests/robustness run once, counted.

Every row (files, recordings, live ports on a virtual fingertip, the network, signals, the
Python API) is judged as the test suite judges it: its exit status, exactly one error line
naming the problem, no traceback, every workspace file and device node unchanged, no hang.
"""
from __future__ import annotations

import logging
import tempfile
from pathlib import Path

from tests.robustness.cases import CASES
from tests.robustness.harness import judge
from tests.robustness.workspace import build

DESCRIPTION = {
    "badinput_cases": ("bad inputs and faults tried (tests/robustness: files, recordings, "
                       "live ports, network, signals, Python API)", (">=", 150)),
    "badinput_handled": ("of those, handled as the table says: exit status, one error line "
                         "naming the problem, no traceback, nothing damaged, no hang",
                         (">=", len(CASES))),
    "badinput_damaged": ("cases after which an input file or a device node had changed",
                         ("<=", 0)),
    "badinput_hangs": ("cases that did not end within their timeout", ("<=", 0)),
}


def run() -> dict[str, int]:
    # The cases' error lines are judged, not shown: a handler on the root logger keeps the
    # command line from printing them (it configures logging only when nobody has).
    logging.getLogger().addHandler(logging.NullHandler())
    with tempfile.TemporaryDirectory(prefix="fingertip-badinput-") as d:
        ws = build(Path(d) / "ws")
        try:
            outcomes = []
            for i, case in enumerate(CASES):
                tmp = Path(d) / "cases" / f"{i:03d}"
                tmp.mkdir(parents=True)
                outcomes.append(judge(case, ws, tmp))
        finally:
            ws.close()
    for o in outcomes:
        if not o.handled:
            print(f"not handled: {o.case}: {'; '.join(o.problems)}")
    return {"badinput_cases": len(outcomes),
            "badinput_handled": sum(o.handled for o in outcomes),
            "badinput_damaged": sum(bool(o.damaged) for o in outcomes),
            "badinput_hangs": sum(o.hung for o in outcomes)}


if __name__ == "__main__":
    print(run())
