"""``fingertip calibrate fit|check DATASET``: fit the force calibration of one fingertip.

:func:`add_parsers` adds ``calibrate`` to the top-level subparsers of ``fingertip``. Handlers
return an exit code, as in :mod:`fingertip.cli`: 0 done; 2 a user error (bad argument,
unreadable dataset, or data that cannot determine the model: one angle only, a dead
channel, too many saturated rows...), reported as one clear log line with its reason code;
1 a failure part-way (writing the outputs, training diverged, ``onnx`` missing).
``python -m fingertip.cli.calibrate fit DATASET`` runs it on its own.
"""
from __future__ import annotations

import argparse
import json
import logging
import sys
from collections.abc import Sequence

from .argtypes import number
from ..badfile import reports_bad_files
log = logging.getLogger("fingertip")


def _models(text: str) -> list[str]:
    from ..models.force.calibrate import expand_models

    try:
        return expand_models(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def _load(args: argparse.Namespace):
    from ..models.force.calibrate import CalibrationError, check_dataset, load_dataset

    try:
        data = load_dataset(args.dataset, unit=args.unit,
                            max_saturated_fraction=args.max_saturated / 100)
        summary = check_dataset(data)
    except CalibrationError as e:
        log.error("cannot calibrate from %s [%s]: %s", args.dataset, e.code, e)
        return None, None
    return data, summary


def _describe(data, summary) -> str:
    d = summary["dropped"]
    return (f"{summary['rows']} rows of {summary['rows_read']} "
            f"({summary['sessions']} session(s): {', '.join(data.sources)}"
            f"{'; unit ' + data.unit if data.unit else ''}); dropped {d['saturated']} "
            f"saturated and {d['timeout']} timed-out; forces up to "
            f"{summary['force_max_n']:.2f} N; condition number {summary['condition_number']:.3g}")


@reports_bad_files
def _cmd_check(args: argparse.Namespace) -> int:
    """Check that a calibration dataset can determine the force model, without fitting."""
    data, summary = _load(args)
    if data is None:
        return 2
    for w in data.warnings:
        log.warning("%s", w)
    if args.json:
        print(json.dumps(summary))
    else:
        print("ok: " + _describe(data, summary))
    return 0


@reports_bad_files
def _cmd_fit(args: argparse.Namespace) -> int:
    """Fit an affine map, polynomials and MLPs from the four strain channels to (Fx, Fy) on
    a calibration dataset (a CSV file or a folder of CSVs: counts c0..c3 or ch0..ch3, fx, fy
    in N, optionally angle_deg, height_mm, trial, masks), test them on held-out cells of the
    protocol, export each to ONNX, time them with onnxruntime, and choose the fastest within
    the error bound. See docs/calibration.md."""
    from ..models.force.calibrate import CalibrationError, fit_calibration

    data, summary = _load(args)
    if data is None:
        return 2
    for w in data.warnings:
        log.warning("%s", w)
    if not args.quiet:
        print("calibrate: " + _describe(data, summary), file=sys.stderr)

    def progress(msg: str) -> None:
        print(f"calibrate: {msg}", file=sys.stderr, flush=True)

    try:
        report = fit_calibration(data, args.out, models=args.models, bound_pct=args.bound,
                                 split=args.split, epochs=args.epochs, seed=args.seed,
                                 progress=None if args.quiet else progress)
    except CalibrationError as e:
        log.error("cannot calibrate from %s [%s]: %s", args.dataset, e.code, e)
        return 2
    except OSError as e:
        log.error("writing into %s failed: %s", args.out, e.strerror or e)
        return 1
    except (FloatingPointError, ImportError) as e:
        log.error("%s", e)
        return 1
    if args.json:
        print(json.dumps(report.as_dict()))
        return 0
    print(f"held out: {report.split}")
    print(f"{report.rows_train} training rows, {report.rows_test} test rows\n")
    print(report.table())
    c = report.chosen_result
    print(f"\nchosen: {c.name} (held-out RMSE {c.rmse_n:.3f} N, MSE {c.mse_n2:.4f} N^2, "
          f"{c.latency_us_single:.1f} us per frame)")
    print(report.rule)
    files = ", ".join(v for k, v in report.files.items() if k != "chosen")
    print(f"wrote {args.out}: force.onnx (= force_{c.name}.onnx), force_<model>.onnx for "
          f"each model, {files}")
    return 0


def add_parsers(sub) -> None:
    """Add ``calibrate`` (with ``fit`` and ``check``) to ``sub``, the top-level subparsers
    of ``fingertip``."""
    from ..models.force.calibrate import DEFAULT_MODELS, MAX_SATURATED_FRACTION

    c = sub.add_parser("calibrate", help="fit the force calibration (counts -> newtons)",
                       description="Force calibration of a fingertip from the paper's indenter "
                                   "protocol (docs/calibration.md).")
    csub = c.add_subparsers(dest="calibrate_command", metavar="ACTION", required=True)

    def common(p: argparse.ArgumentParser) -> None:
        p.add_argument("dataset", metavar="DATASET",
                       help="a calibration CSV, or a folder of them (one session each)")
        p.add_argument("--unit", help="use the rows of this unit only (unit_seed column), "
                                      "when the dataset holds several fingertips")
        p.add_argument("--max-saturated", type=number(float, 0, 1000), metavar="PCT",
                       default=100 * MAX_SATURATED_FRACTION,
                       help="refuse the data when more rows than this are saturated "
                            f"(default {100 * MAX_SATURATED_FRACTION:g}); fewer are dropped")
        p.add_argument("--json", action="store_true", help="print the result as JSON")

    f = csub.add_parser("fit", help="fit, test, export and time the models; choose one",
                        description=_cmd_fit.__doc__)
    common(f)
    f.add_argument("-o", "--out", default="calibration", metavar="OUTDIR",
                   help="output folder (default ./calibration; our files in it are replaced)")
    f.add_argument("--models", type=_models, default=list(DEFAULT_MODELS),
                   help="comma-separated: affine, poly (= poly2,poly3), mlp (= mlp8,mlp16x16,"
                        "mlp32x32), or single names such as poly4, mlp64x64 (default: all)")
    f.add_argument("--bound", type=number(float, 0, 1000), default=10.0, metavar="PCT",
                   help="choose the fastest model whose held-out RMSE is within PCT percent "
                        "of the best (default 10)")
    f.add_argument("--split", choices=("auto", "grid", "trial", "blocks"), default="auto",
                   help="what is held out for testing: whole (angle, height) cells (grid), "
                        "whole trials, or blocks of consecutive readings; auto: the first "
                        "the columns allow")
    f.add_argument("--epochs", type=number(int, 1), default=1500,
                   help="MLP training epochs, at most (default 1500; early stopping)")
    f.add_argument("--seed", type=int, default=0, help="MLP initialisation seed (default 0)")
    f.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    f.set_defaults(func=_cmd_fit)

    k = csub.add_parser("check", help="check that a dataset can determine the model",
                        description=_cmd_check.__doc__)
    common(k)
    k.set_defaults(func=_cmd_check)
    from .calibrate_record import add_parser as add_record_parser

    add_record_parser(csub)


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m fingertip.cli.calibrate fit DATASET ...``"""
    parser = argparse.ArgumentParser(prog="fingertip", description="Force calibration.")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output")
    add_parsers(parser.add_subparsers(dest="command", metavar="COMMAND", required=True))
    args = parser.parse_args(["calibrate", *(sys.argv[1:] if argv is None else argv)])
    logging.basicConfig(level=logging.WARNING - 10 * min(args.verbose, 2),
                        format="%(levelname)s %(name)s: %(message)s")
    return int(args.func(args))


if __name__ == "__main__":
    sys.exit(main())
