"""``fingertip-cad`` / ``python -m fingertip_cad``: build, export and report the fingertip."""
from __future__ import annotations

import argparse
import json
import logging
import sys
from pathlib import Path

from .config import load_params
from .dims import Dims


def _progress(label: str, i: int, n: int) -> None:
    """One line per file on stderr, as it is written: ``[ 5/16] cap.stl``."""
    print(f"[{i + 1:2d}/{n}] {label}", file=sys.stderr, flush=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="fingertip-cad", description=__doc__)
    ap.add_argument("--params", type=Path, help="parameter file (default: the shipped one)")
    ap.add_argument("--set", dest="overrides", action="append", default=[],
                    metavar="SECTION.KEY=VALUE", help="override a parameter (repeatable)")
    ap.add_argument("--out", type=Path, default=Path("build/cad"), help="output folder")
    ap.add_argument("--no-render", action="store_true", help="skip the PNG renders")
    ap.add_argument("--summary", action="store_true",
                    help="only print the key dimensions and the strain per newton")
    ap.add_argument("-v", "--verbose", action="store_true")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING,
                        format="%(levelname)s %(name)s: %(message)s")
    try:
        d = Dims(load_params(args.params, args.overrides))
    except ValueError as e:
        print(f"fingertip-cad: {e}", file=sys.stderr)
        return 2
    s = d.summary
    print(f"envelope {s['envelope_x_mm']:.1f} x {s['envelope_y_mm']:.1f} x "
          f"{s['envelope_z_mm']:.1f} mm (x includes the nail), cap wall {s['cap_wall_mm']:.2f} "
          f"mm, gap {s['cap_gap_mm']:.2f} mm; strain at the gauges "
          f"{s['strain_ue_per_n']:.1f} ue/N (contact at the nail tip, lever "
          f"{s['lever_mm']:.1f} mm)")
    if args.summary:
        return 0
    from .export import export_all   # CadQuery only from here on
    manifest = export_all(d, args.out, renders=not args.no_render, progress=_progress)
    print(json.dumps({k: v["volume_mm3"] for k, v in manifest["parts"].items()}))
    print(f"wrote {args.out}")
    return 0
