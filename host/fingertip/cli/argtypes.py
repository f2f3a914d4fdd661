"""Command-line plumbing shared by every CLI module: ranged numbers, and running a parser
(signals and the mapping of errors to exit statuses: :mod:`.stopping`).

No imports from the rest of the package, so every layer's CLI module can use it.
"""
from __future__ import annotations

import argparse
import math
from collections.abc import Callable, Sequence
from typing import TypeVar

T = TypeVar("T")


def number(kind: type = float, lo: float | None = None, hi: float | None = None, *,
           lo_open: bool = False) -> Callable[[str], float]:
    """An argparse ``type`` that parses ``kind`` (int or float) and checks ``lo`` <= v <= ``hi``
    (``lo`` < v with ``lo_open``). NaN and infinities are always refused."""
    what = "integer" if kind is int else "number"

    def parse(text: str):
        try:
            v = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"invalid {what}: {text!r}") from None
        too_low = lo is not None and (v <= lo if lo_open else v < lo)
        too_high = hi is not None and v > hi
        if not math.isfinite(v) or too_low or too_high:
            parts = []
            if lo is not None:
                parts.append(f"{'above' if lo_open else 'at least'} {lo:g}")
            if hi is not None:
                parts.append(f"at most {hi:g}")
            span = " and ".join(parts) or "finite"
            raise argparse.ArgumentTypeError(f"must be {span}, not {text}")
        return v

    return parse


def channel_list(text: str) -> list[int]:
    """An argparse ``type`` for ``0,1,3``: channel numbers 0..15, each once."""
    try:
        out = [int(c) for c in text.split(",") if c.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"channels are comma-separated numbers 0-15 such as "
                                         f"0,1,3, not {text!r}") from None
    if not out or any(not 0 <= c <= 15 for c in out) or len(set(out)) != len(out):
        raise argparse.ArgumentTypeError(f"channels are distinct numbers 0-15, not {text!r}")
    return out


def parsed(convert: Callable[[str], T]) -> Callable[[str], T]:
    """An argparse ``type`` from a library's own parser (``expand_models``, say): its
    ``ValueError`` becomes argparse's one-line usage error (exit status 2)."""

    def parse(text: str) -> T:
        try:
            return convert(text)
        except ValueError as e:
            raise argparse.ArgumentTypeError(str(e)) from None

    parse.__name__ = getattr(convert, "__name__", "value")
    return parse


def dispatch(parser: argparse.ArgumentParser, argv: Sequence[str] | None = None) -> int:
    """Parse, set up logging from ``-v``, and run the chosen sub-command's ``func`` (help
    and exit status 2 when none was chosen), with the stop signals handled from the start
    and every error turned into one line and an exit status
    (:func:`~fingertip.cli.stopping.run_command`)."""
    from .stopping import configure_logging, interrupted, run_command, stop_signals

    try:
        with stop_signals():
            configure_logging()
            try:
                args = parser.parse_args(argv)
            except KeyboardInterrupt as e:
                return interrupted(e)
            verbose = getattr(args, "verbose", 0) or 0
            configure_logging(verbose)
            if not getattr(args, "func", None):
                parser.print_help()
                return 2
            return run_command(args.func, args, verbose)
    except KeyboardInterrupt as e:  # as the handlers were put in or back (see cli.main)
        configure_logging()
        return interrupted(e)
