"""``fingertip demo``: the whole chain on a virtual fingertip, with a summary on screen."""
from __future__ import annotations

import argparse

import numpy as np


def _cmd_demo(args: argparse.Namespace) -> int:
    """The whole chain on a virtual fingertip: physics -> firmware -> bridge -> events -> PNG."""
    from ..demo import run_demo

    device = {"auto": None, "firmware": True, "python": False}[args.device]
    r = run_demo(args.out, use_firmware=device, seed=args.seed)
    st = r.stats
    print(f"device:      {r.device}")
    print(f"frames:      {st['frames']} (lost {st['frames_lost']}, CRC errors "
          f"{st['crc_errors']})")
    print(f"audio:       {st['audio_frames']} samples at {r.fs:.0f} Hz "
          f"(overruns {st['audio_overflows']})")
    for e in r.events:
        print(f"event        {e.time:7.3f} s  {e.kind}")
    for t0, t1, name in r.materials:
        print(f"material     {t0:7.3f} - {t1:6.3f} s  {name}")
    if len(r.forces):
        print(f"peak force   {float(np.max(np.hypot(r.forces[:, 0], r.forces[:, 1]))):.2f} N")
    print(f"recording:   {r.recording} ({st['recording_messages']} messages, dropped "
          f"{st['recording_dropped']}); try `fingertip replay {r.recording}`")
    print(f"summary:     {r.png}")
    print(f"force model: {r.calibration}")
    print(f"took:        {r.seconds:.0f} s")
    return 0


def add_parsers(sub) -> None:
    """Add ``demo`` to the ``fingertip`` subparsers."""
    dm = sub.add_parser("demo", help="run the whole chain on a virtual fingertip",
                        description=_cmd_demo.__doc__)
    dm.add_argument("--out", default="demo-output", help="folder for the outputs")
    dm.add_argument("--device", choices=("auto", "firmware", "python"), default="auto",
                    help="firmware = the real ELF in simavr; python = its twin; auto = "
                         "firmware when built")
    dm.add_argument("--seed", type=int, default=7, help="which virtual unit")
    dm.set_defaults(func=_cmd_demo)
