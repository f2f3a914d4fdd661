"""What ``fingertip check`` leaves behind: the JSON report (one fingertip, or a hand's
fingertips each under its label), the optional picture, and the tables on stdout."""
from __future__ import annotations

import argparse
import json
import logging
from collections.abc import Sequence
from pathlib import Path

from ..outputs import atomic_output

from .results import Report

log = logging.getLogger("fingertip")


def report_doc(labels: Sequence[str], reports: Sequence[Report], key: str | None = None
               ) -> dict:
    """One report as it is; several as ``{"ok", "fingertips": [...]}``, each tagged
    ``key: label`` when ``key`` is given (a hand's finger names)."""
    if len(reports) == 1 and key is None:
        return reports[0].as_dict()
    return {"ok": all(r.ok for r in reports),
            "fingertips": [({key: label} if key else {}) | r.as_dict()
                           for label, r in zip(labels, reports, strict=True)]}


def finish(args: argparse.Namespace, labels: Sequence[str], reports: Sequence[Report],
           key: str | None = None) -> int:
    """Write the report (``--report``), the picture (``--plot``, one fingertip), print the
    tables or the JSON; the exit code: 0 passed, 1 a check failed, 2 no report written."""
    doc = report_doc(labels, reports, key)
    try:
        with atomic_output(args.report) as tmp:  # a unique temporary file, then renamed
            tmp.write_text(json.dumps(doc, indent=1, default=str) + "\n", encoding="utf-8")
    except OSError as e:
        log.error("cannot write %s: %s", args.report, e.strerror or e)
        return 2
    if args.plot and len(reports) == 1 and "rest" in reports[0].recorded:
        from .plot import plot_check

        report = reports[0]
        plot_check(report.recorded["rest"], report.recorded.get("responses", {}), args.plot,
                   "fingertip check: " + ("all passed" if report.ok else
                                          "failed: " + ", ".join(sorted(report.faults))))
    if args.json:
        print(json.dumps(doc, default=str))
    else:
        for label, report in zip(labels, reports, strict=True):
            if len(reports) > 1 or key:
                print(f"\n== {label}")
            print(report.table())
        print(f"report: {Path(args.report)}")
    return max(r.exit_code() for r in reports)
