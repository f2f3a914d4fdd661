"""``fingertip decode | flash | devices | info | tare | stream``: one fingertip's wire bytes,
firmware and live stream. Handlers return an exit code: 0 done, 1 errors were counted; an
error (wrong port, file, argument: 2; a failure at run time: 1) is raised for
:func:`fingertip.cli.stopping.run_command` to report as one line.
"""
from __future__ import annotations

import argparse
import json
import logging
import sys
from dataclasses import asdict
from pathlib import Path

from ..badfile import check_input
from ..device import Fingertip
from ..device.health import link_text
from ..errors import BadArgumentError, BadFileError
from ..flash import flash
from ..hand_args import add_hand_args, hand_spec_from_args
from ..protocol import RejectedCommand, StreamDecoder, message_to_dict
from ..transport import list_ports
from .argtypes import channel_list, number

log = logging.getLogger("fingertip")


def _cmd_decode(args: argparse.Namespace) -> int:
    """Decode a file of raw wire bytes (a capture of the serial stream)."""
    path = Path(args.file)
    try:
        if args.file != "-":
            check_input(path, "capture of wire bytes")  # a FIFO would block for ever
        data = path.read_bytes() if args.file != "-" else sys.stdin.buffer.read()
    except OSError as e:
        raise BadFileError(f"cannot read {path}: {e.strerror or e}", path) from e
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
        raise BadArgumentError("no serial port: pass --port (e.g. /dev/ttyACM0), or --dry-run")
    r = flash(args.port, args.channels, args.hex, dry_run=args.dry_run, baud=args.baud)
    if not r.ran:
        print(f"dry run: {r.hex_path} holds {r.hex_bytes} bytes; avrdude has no dryrun "
              f"programmer, so it was not run. The upload would run:\n  {' '.join(r.argv)}")
        return 0
    what = "dry run" if args.dry_run else f"flashed {args.port}"
    print(f"{what}: {r.hex_path}, {r.bytes_written if r.bytes_written is not None else '?'} "
          f"bytes written, {r.bytes_verified if r.bytes_verified is not None else '?'} verified")
    return 0


# --- devices ------------------------------------------------------------------------------

def _cmd_devices(args: argparse.Namespace) -> int:
    """List serial ports with their USB identity (and which look like fingertips)."""
    ports = list_ports(include_non_usb=args.all)
    if args.json:
        print(json.dumps([{"device": p.device, "usb_id": p.usb_id,
                           "serial_number": p.serial_number, "location": p.location,
                           "description": p.description} for p in ports]))
        return 0
    if not ports:
        print("no USB serial ports found" + ("" if args.all else " (--all lists every port)"))
        return 0
    print(f"{'port':<22} {'usb id':<10} {'serial number':<24} {'usb path':<12} description")
    for p in ports:
        print(f"{p.device:<22} {p.usb_id:<10} {p.serial_number or '-':<24} "
              f"{p.location or '-':<12} {p.description}")
    return 0


def _open(args: argparse.Namespace) -> Fingertip:
    if args.serial:
        return Fingertip(serial_number=args.serial).open()
    return Fingertip(args.port).open()


def _cmd_info(args: argparse.Namespace) -> int:
    """Show what the device reports about itself, and its counters."""
    with _open(args) as ft:
        info, stats = ft.info, ft.device_stats()
        if args.json:
            print(json.dumps({"info": message_to_dict(info), "stats": message_to_dict(stats),
                              "host": asdict(ft.stats)}))
            return 0
        fw = ".".join(map(str, info.firmware_version))
        print(f"port              {ft.port}")
        print(f"protocol          v{info.protocol_major}.{info.protocol_minor}")
        print(f"firmware          {fw} (build {info.build_id:08x})")
        print(f"channels          {info.channels}")
        print(f"rate              {info.rate_sps} SPS, decimation {info.decimation}")
        print(f"gain              {info.gain}")
        print(f"streaming         {'yes' if info.streaming else 'no'}")
        print(f"tare offsets      {', '.join(map(str, info.tare_offsets))}")
        print(f"reset cause       0x{info.reset_cause:02x}")
        for k, v in message_to_dict(stats).items():
            if k not in ("type", "seq"):
                print(f"{k:<17} {v}")
        print(f"host link         {link_text(ft.stats)}")
    return 0


def _cmd_tare(args: argparse.Namespace) -> int:
    """Average readings on the device and subtract them from then on."""
    with _open(args) as ft:
        offsets = ft.tare(args.channels, samples=args.samples)
        print("tare offsets: " + ", ".join(map(str, offsets)))
    return 0


def _cmd_stream(args: argparse.Namespace) -> int:
    """Stream frames: a live line on a terminal, one line per frame otherwise (or JSON)."""
    from ..stream import StreamSettings, stream_fingertip, stream_hand

    from ..outputs import check_output

    if args.plot_png:  # replaced every second; never a folder, FIFO or device
        check_output(args.plot_png, force=True, what="plot")

    spec = hand_spec_from_args(args)
    settings = StreamSettings(
        count=args.count, duration=args.duration, json=args.json, rate=args.rate,
        decimation=args.decimation, gain=args.gain, tare=args.tare, plot=args.plot,
        plot_png=args.plot_png, force_model=args.force_model)
    line = _LiveLine() if sys.stdout.isatty() and not args.json else None
    try:
        if spec is not None:
            res = stream_hand(settings, spec, out=_print_line)
        else:
            res = stream_fingertip(settings, port=args.port, serial=args.serial,
                                   out=_print_line, live=line, waiting=_print_waiting)
    finally:
        if line is not None and line.used:
            print()  # the live line stays, the summary goes below it
    print(res.text(), file=sys.stderr)
    return 0


def _print_line(text: str) -> None:
    print(text, flush=True)


def _print_waiting(status: str) -> None:
    print(f"\r[{status}]", end="", file=sys.stderr, flush=True)


class _LiveLine:
    """A terminal line that each status rewrites."""

    used = False

    def __call__(self, text: str) -> None:
        self.used = True
        print(f"\r{text}", end="", flush=True)


def _add_device_args(p: argparse.ArgumentParser):
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--port", help="serial port of the fingertip, e.g. /dev/ttyACM0")
    g.add_argument("--serial", help="USB serial number of its Arduino (see `fingertip devices`)")
    return g


def add_parsers(sub) -> None:
    """Add decode, flash, devices, info, tare and stream to the ``fingertip`` subparsers."""
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

    dv = sub.add_parser("devices", help="list serial ports with their USB serial numbers",
                        description=_cmd_devices.__doc__)
    dv.add_argument("--all", action="store_true", help="also ports that are not USB")
    dv.add_argument("--json", action="store_true")
    dv.set_defaults(func=_cmd_devices)

    i = sub.add_parser("info", help="what the device reports about itself",
                       description=_cmd_info.__doc__)
    _add_device_args(i)
    i.add_argument("--json", action="store_true")
    i.set_defaults(func=_cmd_info)

    t = sub.add_parser("tare", help="zero the channels on the device",
                       description=_cmd_tare.__doc__)
    _add_device_args(t)
    t.add_argument("--samples", type=number(int, 1, 256), default=16,
                   help="readings to average (1-256)")
    t.add_argument("--channels", type=channel_list,
                   help="comma-separated channel numbers (default: all)")
    t.set_defaults(func=_cmd_tare)

    st = sub.add_parser("stream", help="show the live frame stream",
                        description=_cmd_stream.__doc__)
    add_hand_args(st, _add_device_args(st))
    st.add_argument("--count", type=int, help="stop after N frames")
    st.add_argument("--duration", type=float, help="stop after S seconds")
    st.add_argument("--json", action="store_true", help="one JSON object per frame")
    st.add_argument("--rate", type=int, choices=(10, 80), help="the chips' rate (RATE pin)")
    st.add_argument("--decimation", type=number(int, 1, 255),
                    help="keep every n-th conversion (1-255)")
    st.add_argument("--gain", type=int, choices=(128, 64, 32))
    st.add_argument("--tare", type=number(int, 1, 256), metavar="N",
                    help="tare with N samples (1-256) first")
    st.add_argument("--plot", action="store_true", help="a live plot in a window")
    st.add_argument("--plot-png", metavar="FILE",
                    help="a live plot written to FILE every second (no screen needed)")
    st.add_argument("--force-model", metavar="FORCE.onnx",
                    help="forces in newtons from this calibration (`calibrate fit|record`): "
                         "on the live line, in the JSON and in the plot")
    st.set_defaults(func=_cmd_stream)
