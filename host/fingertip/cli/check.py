"""``fingertip check``: the bring-up check (:func:`add_parsers` adds it to ``fingertip``).

Exit codes: 0 every check passed (warnings allowed), 1 a check failed; an error (no device
on that port, a bad argument: 2) is raised for the command line's one mapping.
"""
from __future__ import annotations

import argparse
import contextlib
import logging
import sys

from ..check.output import finish
from ..errors import BadArgumentError
from ..hand_args import add_hand_args, hand_spec_from_args
from .argtypes import number

log = logging.getLogger("fingertip")


@contextlib.contextmanager
def _virtual(args: argparse.Namespace):
    """A virtual unit behind a real pty; the simulator performs the guided steps."""
    from ..sim.device.bringup import SimAudio, SimGuide, VirtualUnit
    from ..sim.device.faults import parse_faults
    from ..sim.device.pty_device import PtyDevice

    unit = VirtualUnit(args.seed, parse_faults(args.fault or []))
    with PtyDevice(unit.firmware, speed=args.speed) as dev:
        yield dev.port, SimGuide(unit), SimAudio(unit)


def _real_audio(args: argparse.Namespace, probe):
    if args.no_audio:
        return None
    if args.audio_device is None:
        from ..device.pairing import PairingError, sound_card_for_port

        try:
            device = sound_card_for_port(probe.ft.port, option="--audio-device")
        except PairingError as e:  # the port's own message already names the option
            log.warning("piezo not checked: %s%s", e, "" if "--audio-device" in str(e)
                        else " (give --audio-device)")
            return None
    else:
        device = args.audio_device
    from ..check.audio_capture import SoundCardAudio

    return SoundCardAudio(device, probe)


def _cmd_check(args: argparse.Namespace) -> int:
    """Bring-up check of a new fingertip: the chips, their rate and noise, bridge balance,
    polarity and channel mapping by guided presses, the piezo by guided taps, and the link.
    Prints a table of pass / warn / fail with a one-line fix for each failure, writes a JSON
    report, and exits 1 when something failed (docs/bring-up.md)."""
    from ..device import Fingertip
    from ..check.guide import NoPromptGuide, PromptGuide
    from ..check.probe import DeviceProbe
    from ..check.run import run_check

    from ..outputs import check_output

    # the report (replaced run after run) and the picture: never a folder, FIFO or device
    check_output(args.report, force=True, what="report")
    if args.plot:
        check_output(args.plot, force=True, what="picture")
    if args.fault and not args.virtual:
        raise BadArgumentError("--fault needs --virtual (faults are simulated)")
    say = None if args.quiet else (lambda m: print(f"check: {m}", file=sys.stderr, flush=True))
    if (hand := hand_spec_from_args(args)) is not None:
        from ..check.hand import check_hand

        return finish(args, hand.fingers, check_hand(hand, args, say), key="finger")
    targets = [("port", p) for p in args.port or []] + \
        [("serial", n) for n in args.serial or []] or [("virtual", "")]
    reports = []
    for kind, where in targets:  # a hand: one fingertip after the other
        if len(targets) > 1 and not args.quiet:
            print(f"== {where}", file=sys.stderr)
        with contextlib.ExitStack() as stack:
            if kind == "virtual":
                port, guide, audio = stack.enter_context(_virtual(args))
                if args.no_prompt:
                    guide = NoPromptGuide()
                ft = stack.enter_context(Fingertip(port, command_timeout=2.0))
                probe = DeviceProbe(ft)
            else:
                ft = stack.enter_context(Fingertip(where) if kind == "port" else
                                         Fingertip(serial_number=where))
                probe = DeviceProbe(ft)
                guide = NoPromptGuide() if args.no_prompt else PromptGuide()
                audio = _real_audio(args, probe)
            report = run_check(probe, guide, audio, progress=say)
        if kind == "virtual":
            report.device["virtual"] = {"seed": args.seed, "faults": args.fault or []}
        reports.append(report)
    return finish(args, [where for _, where in targets], reports)


def add_parsers(sub) -> None:
    c = sub.add_parser("check", help="bring-up check of a new fingertip (pass/warn/fail)",
                       description=_cmd_check.__doc__)
    g = c.add_mutually_exclusive_group(required=True)
    g.add_argument("--port", action="append",
                   help="serial port of the fingertip, e.g. /dev/ttyACM0 (repeat for a hand: "
                        "checked one after the other)")
    g.add_argument("--serial", action="append", help="USB serial number of its Arduino")
    g.add_argument("--virtual", action="store_true",
                   help="check a virtual fingertip (the simulator presses and taps)")
    add_hand_args(c, g)
    c.add_argument("--no-prompt", action="store_true",
                   help="skip the guided presses and taps; the report lists what was skipped")
    c.add_argument("--report", default="check-report.json", metavar="FILE.json",
                   help="where to write the JSON report (default check-report.json)")
    c.add_argument("--json", action="store_true", help="print the report as JSON")
    c.add_argument("--plot", metavar="FILE.png",
                   help="also a picture of the rest noise and the presses")
    c.add_argument("--audio-device", metavar="NAME",
                   help="the piezo's sound card (default: the card paired with the port)")
    c.add_argument("--no-audio", action="store_true", help="do not check the piezo")
    c.add_argument("--seed", type=int, default=0, help="--virtual: which unit (default 0)")
    c.add_argument("--fault", action="append", metavar="NAME[:CH]",
                   help="--virtual: a build fault to simulate (repeatable); "
                        "see `fingertip sim faults`")
    c.add_argument("--speed", type=number(float, 0.1, 50.0), default=1.0,
                   help="--virtual: device seconds per wall second (default 1, real time)")
    c.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    c.set_defaults(func=_cmd_check)
