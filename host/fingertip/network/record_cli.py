"""``fingertip record --from dds|zenoh|lsl``: record what `fingertip publish` sends, into
the MCAP file a local recording writes (one clear line and exit 2 for user errors)."""
from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from . import ExtraMissing, require
from .stopper import Stopper

log = logging.getLogger("fingertip")

SOURCE_MODULES = {"dds": "cyclonedds", "zenoh": "zenoh", "lsl": "pylsl"}
"""--from -> the module its extra installs."""


def record_from(args: argparse.Namespace) -> int:
    """``fingertip record --from dds|zenoh|lsl``: what is published, into one MCAP file."""
    from ..record.recorder import Recorder, RecorderError
    from ..record.schemas import check_name
    from .receive import NetworkRecorder

    stopper = Stopper(args.duration)  # a SIGTERM while starting still ends cleanly
    try:
        require(SOURCE_MODULES[args.from_net], f"record --from {args.from_net}")
    except ExtraMissing as e:
        log.error("%s", e)
        return 2
    out = Path(args.output)
    existed = out.exists()
    try:
        names = [check_name(s.strip()) for s in args.name.split(",")]
        rec = Recorder(out, flush_interval=args.flush_interval,
                       flush_bytes=args.flush_kb * 1024, compression=args.compression,
                       overwrite=args.force, fsync=args.fsync).start()
    except (ValueError, RecorderError) as e:
        log.error("%s", e)
        return 2
    try:
        try:
            sink = NetworkRecorder(rec, args.from_net, names,
                                   connect=getattr(args, "zenoh_connect", None),
                                   listen=getattr(args, "zenoh_listen", None))
        except Exception as e:  # DDS or Zenoh that cannot start (bad settings...)
            log.error("%s", e)
            rec.close()
            if not existed:  # nothing was recorded: leave no empty file behind
                out.unlink(missing_ok=True)
            return 2
        print(f"recording {', '.join(names)} from {args.from_net} to {args.output}"
              + (f" for {args.duration:g} s" if args.duration else " (Ctrl-C to stop)"),
              file=sys.stderr, flush=True)
        while stopper.wait() and not rec.failed:
            pass
        sink.close()
    finally:
        s = rec.close()
    print(f"recorded {sum(s.written.values())} messages from {args.from_net} to "
          f"{args.output}: " + ", ".join(f"{k} {v}" for k, v in sorted(s.written.items()))
          + f"; dropped {s.dropped_total}; undecodable {sink.bad}", file=sys.stderr)
    if rec.error is not None:
        log.error("%s", rec.error)
        return 1
    return 0
