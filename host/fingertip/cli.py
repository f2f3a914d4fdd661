"""The ``fingertip`` command line: thin, it parses arguments and calls the library."""
from __future__ import annotations

import argparse
import json
import logging
import sys
from collections.abc import Sequence
from pathlib import Path

from . import __version__
from .flash import FlashError, flash
from .protocol import (
    PROTOCOL_MAJOR,
    PROTOCOL_MINOR,
    RejectedCommand,
    StreamDecoder,
    message_to_dict,
)

log = logging.getLogger("fingertip")


def _cmd_decode(args: argparse.Namespace) -> int:
    """Decode a file of raw wire bytes (a capture of the serial stream)."""
    path = Path(args.file)
    try:
        data = path.read_bytes() if args.file != "-" else sys.stdin.buffer.read()
    except OSError as e:
        log.error("cannot read %s: %s", path, e.strerror or e)
        return 2
    dec = StreamDecoder(args.direction)
    shown = 0
    for item in dec.feed(data):
        if args.limit is not None and shown >= args.limit:
            continue
        shown += 1
        if isinstance(item, RejectedCommand):
            print(f"rejected command 0x{item.command:02X} request {item.request_id}: "
                  f"{item.error.name} ({item.reason})")
        elif args.json:
            print(json.dumps(message_to_dict(item)))
        else:
            print(item)
    counters = dec.stats.as_dict()
    if dec.pending_bytes:
        counters["unterminated_bytes"] = dec.pending_bytes
    print(json.dumps({"counters": counters}) if args.json else
          "counters: " + ", ".join(f"{k}={v}" for k, v in counters.items()), file=sys.stderr)
    return 0 if dec.stats.errors_total == 0 else 1


def _cmd_flash(args: argparse.Namespace) -> int:
    """Upload the firmware to an Arduino Uno with avrdude (builds the HEX if it is missing)."""
    if not args.port and not args.dry_run:
        log.error("no serial port: pass --port (e.g. /dev/ttyACM0), or --dry-run")
        return 2
    try:
        r = flash(args.port, args.channels, args.hex, dry_run=args.dry_run, baud=args.baud)
    except FlashError as e:
        log.error("%s", e)
        return e.code
    if not r.ran:
        print(f"dry run: {r.hex_path} holds {r.hex_bytes} bytes; avrdude has no dryrun "
              f"programmer, so it was not run. The upload would run:\n  {' '.join(r.argv)}")
        return 0
    what = "dry run" if args.dry_run else f"flashed {args.port}"
    print(f"{what}: {r.hex_path}, {r.bytes_written if r.bytes_written is not None else '?'} "
          f"bytes written, {r.bytes_verified if r.bytes_verified is not None else '?'} verified")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="fingertip",
        description="Host bridge of the open-source multi-modal tactile fingertip.")
    p.add_argument("--version", action="version",
                   version=f"fingertip {__version__} (wire protocol v{PROTOCOL_MAJOR}."
                           f"{PROTOCOL_MINOR})")
    p.add_argument("-v", "--verbose", action="count", default=0, help="more log output")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    d = sub.add_parser("decode", help="decode a capture of raw wire bytes and count errors",
                       description=_cmd_decode.__doc__)
    d.add_argument("file", help="file of raw bytes as read from the serial port ('-' = stdin)")
    d.add_argument("--direction", choices=("device", "host"), default="device",
                   help="who sent the bytes (default: device)")
    d.add_argument("--json", action="store_true", help="one JSON object per message")
    d.add_argument("--limit", type=int, default=None, help="print at most N messages")
    d.set_defaults(func=_cmd_decode)

    f = sub.add_parser("flash", help="upload the firmware to an Arduino Uno with avrdude",
                       description=_cmd_flash.__doc__)
    f.add_argument("--port", help="serial port of the Uno, e.g. /dev/ttyACM0")
    f.add_argument("--channels", type=int, choices=(4, 16), default=4,
                   help="firmware build: 4 channels (one fingertip, default) or 16")
    f.add_argument("--hex", help="HEX file to upload (default: the build of --channels in "
                                 "firmware/build, made with `make -C firmware all` if missing)")
    f.add_argument("--baud", type=int, default=115200,
                   help="bootloader baud rate (default: 115200, the Uno's optiboot)")
    f.add_argument("--dry-run", action="store_true",
                   help="run avrdude with its 'dryrun' programmer: nothing is written")
    f.set_defaults(func=_cmd_flash)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.WARNING - 10 * min(args.verbose, 2),
                        format="%(levelname)s %(name)s: %(message)s")
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    return int(args.func(args))


if __name__ == "__main__":
    sys.exit(main())
