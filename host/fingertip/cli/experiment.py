"""``fingertip experiment pinch|cups|shake``: the paper's manipulation protocols on the
simulated hand, with per-trial variation, printed as the paper's results tables.

:func:`add_parsers` adds ``experiment`` to the top-level subparsers of ``fingertip``.
Handlers return 0 when the trials ran (failed trials are results, shown in the table and
its failure modes); a user error (an unwritable ``--json`` file) is raised: exit status 2.
"""
from __future__ import annotations

import argparse
import json
import logging
import math
from pathlib import Path

from ..errors import OutputRefused
from .argtypes import number

log = logging.getLogger("fingertip")

DEFAULT_TRIALS = {"pinch": 25, "cups": 36, "shake": 56}
"""The paper's counts: 25 per object, 36 cup trials, 28 per target material."""


def _json_safe(x):
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: _json_safe(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_json_safe(v) for v in x]
    return x


def _cmd_experiment(args: argparse.Namespace) -> int:
    """Run the paper's protocol on the virtual fingertips of a simulated four-finger hand
    (seeds SEED .. SEED + N - 1, each varying the world) and print the results table."""
    from ..sim.dataset import Progress
    from ..sim import experiment as ex

    n = args.trials or DEFAULT_TRIALS[args.protocol]
    if args.json is not None:
        try:
            args.json.parent.mkdir(parents=True, exist_ok=True)
            args.json.touch()
        except OSError as e:  # refused before any trial runs: the path the user gave
            raise OutputRefused(f"cannot write {args.json}: {e.strerror or e}") from e
    objects = ("tofu", "chip") if args.object == "both" else (args.object,)
    total = n * len(objects) if args.protocol == "pinch" else n
    bar = Progress(total, f"experiment {args.protocol}", enabled=not args.quiet)
    if args.protocol == "pinch":
        results = [ex.run_pinch(o, n, args.seed, bar.step, f_th_n=args.threshold)
                   for o in objects]
        table = ex.pinch_table(results)
        data = {"protocol": "pinch", "seed": args.seed,
                "objects": [r.to_dict() for r in results]}
        title = f"Pinch: {n} trials per object (seeds {args.seed}..{args.seed + n - 1})"
    elif args.protocol == "cups":
        r = ex.run_cups(n, args.seed, bar.step)
        table, data = ex.cups_table(r), r.to_dict()
        title = (f"Cup counting and unstacking: {n} trials (seeds {args.seed}.."
                 f"{args.seed + n - 1}), five cups, 21 mm slide, target 1-3 cups")
    else:
        r = ex.run_shake(n, args.seed, bar.step)
        table, data = ex.shake_table(r), r.to_dict()
        title = (f"Shake-and-pick: {n} trials (seeds {args.seed}..{args.seed + n - 1}), "
                 f"0.67 Hz, 50 mm, 5.6 s, majority vote of 10 Hz predictions")
    print(title)
    print()
    print(table, end="")
    if args.json is not None:
        args.json.write_text(json.dumps(_json_safe(data), indent=1) + "\n", encoding="utf-8")
        print(f"\nwrote {args.json}")
    return 0


def add_parsers(sub) -> None:
    """Add ``experiment`` to ``sub``, the top-level subparsers of ``fingertip``."""
    p = sub.add_parser("experiment", help="run the paper's manipulation protocols (pinch, "
                                          "cups, shake) in simulation",
                       description=_cmd_experiment.__doc__)
    p.add_argument("protocol", choices=("pinch", "cups", "shake"),
                   help="pinch: one demonstration (tofu held at 0.5 N, a chip at 0.1 N) "
                        "gives F_th, then each trial closes to it and lifts; cups: count rims and "
                        "unstack 1-3 cups; shake: find and open the box with the target "
                        "material")
    p.add_argument("--trials", type=number(int, 1, 10_000), metavar="N",
                   help="trials (per object for pinch); default the paper's: pinch 25, "
                        "cups 36, shake 56")
    p.add_argument("--seed", type=number(int, 0, 2 ** 31 - 1), default=0, metavar="S",
                   help="seed of the first trial (default 0)")
    p.add_argument("--object", choices=("tofu", "chip", "both"), default="both",
                   help="pinch only: which object (default both)")
    p.add_argument("--threshold", type=number(float, 0.0, 10.0, lo_open=True), metavar="N",
                   help="pinch only: use this F_th in newtons instead of a demonstration")
    p.add_argument("--json", type=Path, metavar="FILE",
                   help="also write every trial and the summary as JSON")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    p.set_defaults(func=_cmd_experiment)
