"""``fingertip calibrate record``: record (or load) a fingertip and a reference, join them
by time and fit. Exit codes: 0 done; 2 bad input (no reference packets, a reference that
never moves, a wrong CSV, clocks that cannot be aligned), raised as the package's errors
for the command line's one line, nothing fitted; 1 a failure part-way (writing the outputs)."""
from __future__ import annotations

import argparse
import contextlib
import logging
import sys

from ..errors import EXIT_FAILED, BadArgumentError, Error
from .argtypes import number, parsed

log = logging.getLogger("fingertip")


def _rdt_address(text: str) -> tuple[str, int]:
    """``HOST``, ``HOST:PORT``, ``[IPv6]``, ``[IPv6]:PORT`` or a bare IPv6 address -> (host,
    port); the port 1-65535 (default 49152) and the host must resolve."""
    import socket

    host, port = text, ""
    if text.startswith("["):
        host, bracket, rest = text[1:].partition("]")
        if not bracket:
            raise argparse.ArgumentTypeError(f"{text!r}: no closing ']': give [IPv6]:PORT")
        if rest and not rest.startswith(":"):
            raise argparse.ArgumentTypeError(f"{text!r}: give [IPv6]:PORT")
        port = rest[1:]
    elif text.count(":") == 1:
        host, port = text.split(":")
    if not host:
        raise argparse.ArgumentTypeError(f"{text!r}: no host: give HOST or HOST:PORT")
    try:
        port_n = int(port) if port else 49152
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: the port must be a number 1-65535, "
                                         f"not {port!r}") from None
    if not 1 <= port_n <= 65535:
        raise argparse.ArgumentTypeError(f"{text!r}: the port must be 1-65535, not {port_n}")
    try:
        socket.getaddrinfo(host, port_n, type=socket.SOCK_DGRAM)
    except (OSError, UnicodeError) as e:
        raise argparse.ArgumentTypeError(f"{host!r}: unknown host "
                                         f"({getattr(e, 'strerror', None) or e})") from None
    return host, port_n


def _cmd_record(args: argparse.Namespace) -> int:
    """Record a calibration run with a reference force sensor, join the two by time (the
    clock offset is estimated from the data, with its uncertainty), drop unsettled samples
    and fit the force models (docs/calibration.md, docs/bring-up.md). References: an ATI
    Net F/T or Axia over RDT (--rdt), or a timestamped CSV (--reference-csv, with the
    fingertip live or from --fingertip-csv). --virtual runs it all on a virtual fingertip
    with a simulated RDT sensor on 127.0.0.1."""
    from ..device import Fingertip
    from ..reference.rdt import RdtClient
    from ..models.force.calib_session import fit_run, join_csvs, record_and_join
    from ..models.force.calibrate import CalibrationError

    say = None if args.quiet else (lambda m: print(f"calibrate: {m}", file=sys.stderr,
                                                    flush=True))
    with contextlib.ExitStack() as stack:
        if args.fingertip_csv:
            if not args.reference_csv:
                raise BadArgumentError("--fingertip-csv needs --reference-csv")
            run = join_csvs(args.fingertip_csv, args.reference_csv,
                            time_column=args.time_column, serial=args.device_serial or "",
                            max_lag_s=args.max_offset)
        else:
            if not (args.virtual or args.port or args.serial):
                raise BadArgumentError("give the fingertip: --port, --serial or --virtual (or "
                                       "--fingertip-csv with --reference-csv)")
            begin = None
            if args.virtual:
                from ..sim.device.reference_rig import virtual_rdt_rig

                port, addr, begin = stack.enter_context(virtual_rdt_rig(
                    args.seed, args.duration, delay_s=args.sim_delay_ms / 1e3,
                    loss=args.sim_loss / 100))
                args.rdt = args.rdt or _rdt_address(addr)
                ft = stack.enter_context(Fingertip(port))
                serial = f"virtual-{args.seed}"
            else:
                ft = stack.enter_context(Fingertip(args.port) if args.port else
                                         Fingertip(serial_number=args.serial))
                serial = args.device_serial or ft.serial_number or ""
            if not (args.rdt or args.ros_topic):
                raise BadArgumentError("give a reference: --rdt HOST[:PORT], --ros-topic TOPIC "
                                       "or --reference-csv FILE (with --fingertip-csv)")
            src = _network_reference(args) if args.ros_topic else \
                RdtClient(args.rdt[0], args.rdt[1], counts_per_force=args.counts_per_force,
                          counts_per_torque=args.counts_per_force)
            run = record_and_join(ft, src, args.duration, serial=serial,
                                  reference_csv=args.reference_csv,
                                  max_lag_s=args.max_offset, before=begin, progress=say)
    print(run.alignment_text())
    try:
        report = fit_run(run, args.out, models=args.models, progress=say)
    except CalibrationError as e:
        e.add_context(f"cannot calibrate from the joined data [{e.code}]")
        raise
    except OSError as e:  # the folder was accepted before the fit: a failure part-way
        raise Error(f"writing into {args.out} failed: {e.strerror or e}",
                    exit_code=EXIT_FAILED) from e
    print(report.chosen_text(args.out, ("joined.csv", "alignment.json")))
    return 0


def _masses(text: str) -> list[float]:
    """``--masses 50,100,200``: grams."""
    try:
        return [float(m) for m in text.split(",")]
    except ValueError:
        raise BadArgumentError(f"--masses: grams separated by commas, not {text!r}") from None


def _cmd_weights(args: argparse.Namespace) -> int:
    """Calibrate with known weights, no force sensor needed: turn the fingertip so that a
    weight hung from its nail pulls along each direction in turn, enter each mass (at least
    three per direction, both axes), and the models are fitted on the settled readings
    (docs/bring-up.md). --virtual: the simulator hangs the weights."""
    from ..device import Fingertip
    from ..models.force.calibrate import CalibrationError, fit_calibration
    from ..models.force.weights import DIRECTIONS, PromptWeightsGuide, record_weights

    dirs = [d.strip().upper() for d in args.directions.split(",")]
    bad = [d for d in dirs if d not in DIRECTIONS]
    if bad:
        raise BadArgumentError(f"unknown direction(s) {', '.join(bad)}: use "
                               f"{', '.join(DIRECTIONS)}")
    say = None if args.quiet else (lambda m: print(f"weights: {m}", file=sys.stderr,
                                                    flush=True))
    try:
        with contextlib.ExitStack() as stack:
            if args.virtual:
                from ..sim.device.bringup import SimWeightsGuide, VirtualUnit
                from ..sim.device.pty_device import PtyDevice

                unit = VirtualUnit(args.seed)
                dev = stack.enter_context(PtyDevice(unit.firmware, speed=args.speed))
                ft = stack.enter_context(Fingertip(dev.port))
                guide = SimWeightsGuide(unit, _masses(args.masses))
                serial = f"virtual-{args.seed}"
            else:
                ft = stack.enter_context(Fingertip(args.port) if args.port else
                                         Fingertip(serial_number=args.serial))
                guide = PromptWeightsGuide()
                serial = args.device_serial or ft.serial_number or ""
            session = record_weights(ft, guide, dirs, say=say)
            gain = int(ft.info.gain)
        data = session.dataset(gain=gain, unit=serial)
        report = fit_calibration(data, args.out, models=args.models, split="trial",
                                 extra_metadata={"device_serial": serial,
                                                 "reference": "known weights"})
    except CalibrationError as e:
        e.add_context(f"cannot calibrate [{e.code}]")
        raise
    except OSError as e:  # the folder was accepted before the fit: a failure part-way
        raise Error(f"writing into {args.out} failed: {e.strerror or e}",
                    exit_code=EXIT_FAILED) from e
    print(report.chosen_text(args.out, how=" over whole weight steps"))
    return 0


def _network_reference(args: argparse.Namespace):
    """--ros-topic: a geometry_msgs/WrenchStamped topic over DDS or Zenoh (an optional
    extra: its absence is one line naming it)."""
    from ..network.reference import WrenchTopicSource

    return WrenchTopicSource(args.ros_topic, args.ros_transport)


def add_parser(csub) -> None:
    from ..models.force.calibrate import expand_models

    r = csub.add_parser("record", help="record with a reference sensor, align clocks, fit",
                        description=_cmd_record.__doc__)
    g = r.add_mutually_exclusive_group()
    g.add_argument("--port", help="serial port of the fingertip")
    g.add_argument("--serial", help="USB serial number of its Arduino")
    g.add_argument("--virtual", action="store_true",
                   help="a virtual fingertip with a simulated RDT sensor on 127.0.0.1")
    r.add_argument("--rdt", type=_rdt_address, metavar="HOST[:PORT]",
                   help="an ATI Net F/T or Axia streaming RDT (UDP, default port 49152)")
    r.add_argument("--ros-topic", metavar="TOPIC",
                   help="a geometry_msgs/WrenchStamped topic (e.g. /ft_sensor/wrench) from a "
                        "reference on the ROS 2 network (extra: fingertip[ros] or [zenoh])")
    r.add_argument("--ros-transport", choices=("dds", "zenoh"), default="dds",
                   help="--ros-topic over DDS (rmw_cyclonedds/fastrtps) or rmw_zenoh "
                        "(default dds)")
    r.add_argument("--counts-per-force", type=number(float, 1e-9), default=1_000_000,
                   help="the sensor's counts per newton (its cfgcpf; default 1000000)")
    r.add_argument("--reference-csv", metavar="FILE",
                   help="a reference CSV: time (s), fx, fy (N)[, fz]")
    r.add_argument("--fingertip-csv", metavar="FILE",
                   help="the fingertip from a `fingertip export` CSV instead of live")
    r.add_argument("--time-column", default="host_time",
                   help="--fingertip-csv's time column (host_time or unix_time)")
    r.add_argument("--device-serial", help="the fingertip's serial, written into the model")
    r.add_argument("--duration", type=number(float, 5.0, 3600.0), default=90.0,
                   help="seconds to record (default 90)")
    r.add_argument("--max-offset", type=number(float, 0.05, 600.0), default=2.0,
                   metavar="S", help="search the clock offset within +-S seconds (default 2)")
    r.add_argument("-o", "--out", default="calibration", metavar="OUTDIR")
    r.add_argument("--models", type=parsed(expand_models), default=["affine", "poly2", "mlp16x16"],
                   help="models to fit (default affine,poly2,mlp16x16)")
    r.add_argument("--seed", type=int, default=0, help="--virtual: which unit")
    r.add_argument("--sim-delay-ms", type=float, default=37.0,
                   help="--virtual: the simulated sensor's lag (default 37 ms)")
    r.add_argument("--sim-loss", type=number(float, 0, 50), default=1.0, metavar="PCT",
                   help="--virtual: packets lost (default 1 %%)")
    r.add_argument("-q", "--quiet", action="store_true")
    r.set_defaults(func=_cmd_record)

    w = csub.add_parser("weights", help="calibrate with known weights (no F/T sensor)",
                        description=_cmd_weights.__doc__)
    g = w.add_mutually_exclusive_group(required=True)
    g.add_argument("--port", help="serial port of the fingertip")
    g.add_argument("--serial", help="USB serial number of its Arduino")
    g.add_argument("--virtual", action="store_true", help="a virtual fingertip")
    w.add_argument("--directions", default="+X,+Y,-X,-Y",
                   help="directions of the pull, in order (default +X,+Y,-X,-Y)")
    w.add_argument("--masses", default="50,100,200,300",
                   help="--virtual: the masses hung in each direction, grams")
    w.add_argument("--device-serial", help="the fingertip's serial, written into the model")
    w.add_argument("-o", "--out", default="calibration", metavar="OUTDIR")
    w.add_argument("--models", type=parsed(expand_models), default=["affine"],
                   help="models to fit (default affine: a few weights determine little more)")
    w.add_argument("--seed", type=int, default=0, help="--virtual: which unit")
    w.add_argument("--speed", type=number(float, 0.1, 20.0), default=1.0,
                   help="--virtual: device seconds per wall second")
    w.add_argument("-q", "--quiet", action="store_true")
    w.set_defaults(func=_cmd_weights)
