"""``fingertip calibrate fit|check DATASET``: fit the force calibration of one fingertip.

:func:`add_parsers` adds ``calibrate`` to the top-level subparsers of ``fingertip``. Exit
status 0 done; 2 a user error (bad argument, unreadable dataset, or data that cannot
determine the model: one angle only, a dead channel, too many saturated rows...), raised
with its reason code for the command line's one mapping; 1 a failure part-way (writing the
outputs, training diverged, ``onnx`` missing).
``python -m fingertip.cli.calibrate fit DATASET`` runs it on its own.
"""
from __future__ import annotations

import argparse
import json
import logging
import sys
from collections.abc import Sequence

from ..errors import EXIT_FAILED, Error, ModelError
from .argtypes import dispatch, number, parsed
from ..badfile import reports_bad_files

log = logging.getLogger("fingertip")


def _load(args: argparse.Namespace):
    from ..models.force.calibrate import CalibrationError, check_dataset, load_dataset

    try:
        data = load_dataset(args.dataset, unit=args.unit,
                            max_saturated_fraction=args.max_saturated / 100)
        summary = check_dataset(data)
    except CalibrationError as e:
        e.add_context(f"cannot calibrate from {args.dataset} [{e.code}]")
        raise
    return data, summary


@reports_bad_files
def _cmd_check(args: argparse.Namespace) -> int:
    """Check that a calibration dataset can determine the force model, without fitting."""
    from ..models.force.calibrate import describe

    data, summary = _load(args)
    for w in data.warnings:
        log.warning("%s", w)
    if args.json:
        print(json.dumps(summary))
    else:
        print("ok: " + describe(data, summary))
    return 0


@reports_bad_files
def _cmd_fit(args: argparse.Namespace) -> int:
    """Fit an affine map, polynomials and MLPs from the four strain channels to (Fx, Fy) on
    a calibration dataset (a CSV file or a folder of CSVs: counts c0..c3 or ch0..ch3, fx, fy
    in N, optionally angle_deg, height_mm, trial, masks), test them on held-out cells of the
    protocol, export each to ONNX, time them with onnxruntime, and choose the fastest within
    the error bound. See docs/calibration.md."""
    from ..models.force.calibrate import CalibrationError, describe, fit_calibration
    from ..outputs import check_output

    check_output(args.out, force=True, what="calibration folder", folder=True)
    data, summary = _load(args)
    for w in data.warnings:
        log.warning("%s", w)
    if not args.quiet:
        print("calibrate: " + describe(data, summary), file=sys.stderr)

    def progress(msg: str) -> None:
        print(f"calibrate: {msg}", file=sys.stderr, flush=True)

    try:
        report = fit_calibration(data, args.out, models=args.models, bound_pct=args.bound,
                                 split=args.split, epochs=args.epochs, seed=args.seed,
                                 progress=None if args.quiet else progress)
    except CalibrationError as e:
        e.add_context(f"cannot calibrate from {args.dataset} [{e.code}]")
        raise
    except OSError as e:  # the folder was accepted before the fit: a failure part-way
        raise Error(f"writing into {args.out} failed: {e.strerror or e}",
                    exit_code=EXIT_FAILED) from e
    except (FloatingPointError, ImportError) as e:  # training diverged, onnx missing
        raise ModelError(str(e)) from e
    if args.json:
        print(json.dumps(report.as_dict()))
        return 0
    print(report.fit_text(args.out))
    return 0


def add_parsers(sub) -> None:
    """Add ``calibrate`` (with ``fit`` and ``check``) to ``sub``, the top-level subparsers
    of ``fingertip``."""
    from ..models.force.calibrate import DEFAULT_MODELS, MAX_SATURATED_FRACTION, expand_models

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
    f.add_argument("--models", type=parsed(expand_models), default=list(DEFAULT_MODELS),
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
    return dispatch(parser, ["calibrate", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    sys.exit(main())
