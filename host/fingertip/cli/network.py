"""``fingertip publish`` and ``fingertip record --from dds|zenoh|lsl``: the command-line side
of the network transports. Handlers return 0 done, or 1 when a recording got nothing in
time or failed part-way; an error is raised for the command line's one mapping (2 a user
error, 1 a failure at run time)."""
from __future__ import annotations

import argparse
import contextlib
import logging
import sys
from typing import Any

from ..errors import BadArgumentError
from ..hand_args import add_hand_args, hand_audio_from_args, hand_spec_from_args
from ..network import TRANSPORTS
from .argtypes import number

log = logging.getLogger("fingertip")


def _virtual_ports(n: int, seed: int, stack: contextlib.ExitStack) -> list[str]:
    """``--virtual N``: N idle virtual fingertips on ptys (the simulator sits above the
    network layer, so the command line opens them and hands their ports down)."""
    from ..sim.device.pty_device import virtual_fingertip_ports

    return virtual_fingertip_ports(n, seed, stack)


def _open_sources(args: argparse.Namespace, stack: contextlib.ExitStack, hand) -> list[Any]:
    """The fingertips to publish: a hand's fingers, a replay, virtual ones or real ones."""
    from ..network import publish_sources as ps

    if hand is not None:
        return ps.open_hand(hand, stack)
    if args.replay:
        return [ps.open_replay(args.replay, args.name.split(",")[0] if args.name else None,
                               stack, speed=args.speed, rebase=not args.sim_time)]
    ports = (_virtual_ports(args.virtual, args.seed, stack) if args.virtual
             else args.port or [])
    return ps.open_fingertips(ports, args.serial or [], stack)


def _say(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def _record_from(args: argparse.Namespace) -> int:
    """``fingertip record --from dds|zenoh|lsl``: what is published, into one MCAP file."""
    from ..network.record_from import record_network
    from ..outputs import check_output

    check_output(args.output, force=args.force, what="recording")  # no FIFO, no overwrite
    r = record_network(args.from_net, args.name, args.output, duration=args.duration,
                       flush_interval=args.flush_interval,
                       flush_bytes=args.flush_kb * 1024, compression=args.compression,
                       overwrite=args.force, fsync=args.fsync,
                       connect=getattr(args, "zenoh_connect", None),
                       listen=getattr(args, "zenoh_listen", None),
                       wait_timeout=args.wait_timeout, say=_say)
    if r.timed_out is not None and not r.written:
        log.error("%s", r.timed_out)
        return 1
    print(f"recorded {sum(r.written.values())} messages from {args.from_net} to "
          f"{args.output}: " + ", ".join(f"{k} {v}" for k, v in sorted(r.written.items()))
          + f"; dropped {r.dropped}; undecodable {r.undecodable}", file=sys.stderr)
    if r.error is not None:
        log.error("%s", r.error)
        return 1
    if r.timed_out is not None:
        log.error("%s", r.timed_out)
        return 1
    return 0


def _cmd_publish(args: argparse.Namespace) -> int:
    """Publish fingertips live on the network: ROS 2 topics /fingertip/NAME/raw|wrench|
    audio|events|info over DDS (default) or Zenoh, or Lab Streaming Layer outlets."""
    from ..network import publish_sources as ps
    from ..network.hand import hand_conflict
    from ..network.publish import PublishSettings, publish
    from ..record.recorder import Recorder

    if args.record:
        from ..outputs import check_output

        check_output(args.record, force=args.force, what="recording")
    hand = hand_spec_from_args(args)
    if (why := hand_conflict(args, hand)) is not None:
        raise BadArgumentError(why)
    if (args.material_model or args.shake_model) and not (
            args.audio or args.audio_file or args.virtual_audio):
        raise BadArgumentError("--material-model and --shake-model classify the microphone: "
                               "add --audio, --audio-file or --virtual-audio")
    from .record import load_force_model

    force_model = load_force_model(args.force_model) if args.force_model else None
    classifiers = ps.load_classifiers(args.material_model, args.shake_model)
    with contextlib.ExitStack() as stack:
        transport = ps.make_transport(args.transport, args.zenoh_connect, args.zenoh_listen)
        stack.callback(transport.close)
        sources = _open_sources(args, stack, hand)
        if args.force_model and args.force_model.lower().endswith(".onnx"):
            force_model = ps.checked_force_model(args.force_model, sources, force_model)
        names = ([s.name for s in sources] if args.replay or hand else
                 ps.publish_names(args.name, len(sources)))
        audio = ps.audio_source(args.audio, args.audio_file, args.virtual_audio,
                                args.audio_rate, args.port)
        hand_audio = [] if hand is None else hand_audio_from_args(
            args, names, sample_rate=args.audio_rate)
        rec = None
        if args.record:
            rec = Recorder(args.record, overwrite=args.force).start()
            stack.callback(rec.close)
        timebase = rec.timebase if rec is not None else None
        if args.sim_time:
            if not args.replay:
                raise BadArgumentError("--sim-time goes with --replay (a live device runs on "
                                       "ROS time)")
            timebase = sources[0].recording.timebase  # the recording's own stamps
        settings = PublishSettings(
            transport_name=args.transport, duration=args.duration, replay=bool(args.replay),
            sim_time=args.sim_time, tare=args.tare, read_only=args.read_only,
            service_tare_samples=args.service_tare_samples,
            wait_subscribers=args.wait_subscribers, wait_timeout=args.wait_timeout,
            linger=args.linger, audio_rate=args.audio_rate)
        publish(transport, sources, names, settings=settings, force_model=force_model,
                classifiers=classifiers, audio=audio, hand_audio=hand_audio, rec=rec,
                timebase=timebase, say=_say)
    return 0


# --- parser -----------------------------------------------------------------------------------

def add_zenoh_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--zenoh-connect", action="append", metavar="ENDPOINT",
                   help="Zenoh: a router (or peer) to connect to, e.g. tcp/192.168.1.2:7447 "
                        "(repeatable)")
    p.add_argument("--zenoh-listen", action="append", metavar="ENDPOINT",
                   help="Zenoh: listen for peers here, e.g. tcp/127.0.0.1:7448 (repeatable)")


def add_parsers(sub) -> None:
    """Add ``publish``, and the Zenoh options of ``record --from`` to ``record`` (added
    before, by the record package, which does not import this one)."""
    rec = sub.choices.get("record")
    if rec is not None:
        add_zenoh_args(rec)
        local = rec.get_default("func")

        def record(args: argparse.Namespace) -> int:
            return _record_from(args) if args.from_net else local(args)
        record.__doc__ = local.__doc__
        rec.set_defaults(func=record)
    p = sub.add_parser("publish", help="publish fingertips live: ROS 2 (DDS, Zenoh) or LSL",
                       description=_cmd_publish.__doc__)
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--port", action="append", help="serial port of a fingertip (repeat for "
                   "a hand of several)")
    g.add_argument("--serial", action="append", help="USB serial number of a fingertip's "
                   "Arduino (repeatable)")
    g.add_argument("--replay", metavar="FILE.mcap", help="publish a recording")
    g.add_argument("--virtual", type=number(int, 1, 16), metavar="N",
                   help="N virtual fingertips (no hardware)")
    add_hand_args(p, g)
    p.add_argument("--transport", choices=TRANSPORTS, default="dds",
                   help="dds (ROS 2, default), zenoh (ROS 2 with rmw_zenoh) or lsl (Lab "
                        "Streaming Layer)")
    add_zenoh_args(p)
    p.add_argument("--name", help="comma-separated names, one per fingertip, for topics "
                   "/fingertip/NAME/... (default: fingertip, or finger0, finger1...)")
    p.add_argument("--force-model", metavar="MODEL.onnx|MODULE:FUNCTION",
                   help="forces published as geometry_msgs/WrenchStamped on .../wrench")
    p.add_argument("--material-model", metavar="MODEL.onnx",
                   help="classify the microphone's audio (`fingertip classify train "
                        "material`): predictions as `material` events")
    p.add_argument("--shake-model", metavar="MODEL.onnx",
                   help="the same with a shake model: `shake` events")
    a = p.add_mutually_exclusive_group()
    a.add_argument("--audio", metavar="DEVICE",
                   help="the sound card of the (first) fingertip: index, part of its name, "
                        "or `paired` (the card on the same USB hub as --port)")
    a.add_argument("--audio-file", metavar="WAV", help="a WAV file as the microphone")
    a.add_argument("--virtual-audio", action="store_true", help="a simulated microphone")
    p.add_argument("--audio-rate", type=number(float, 0, lo_open=True), default=44100.0)
    p.add_argument("--tare", type=number(int, 1, 65535), metavar="N",
                   help="tare with N samples first")
    p.add_argument("--read-only", action="store_true",
                   help="serve no service that changes the device (no tare service)")
    p.add_argument("--service-tare-samples", type=number(int, 1, 65535), default=16,
                   metavar="N", help="samples the tare service averages (default 16)")
    p.add_argument("--duration", type=number(float, 0, lo_open=True), metavar="S")
    p.add_argument("--speed", type=number(float, 0, lo_open=True), default=1.0,
                   help="--replay speed (default 1.0)")
    p.add_argument("--seed", type=int, default=0, help="--virtual: which virtual units")
    p.add_argument("--sim-time", action="store_true",
                   help="--replay: keep the recording's stamps and publish /clock, for "
                        "subscribers with use_sim_time")
    p.add_argument("--record", metavar="FILE.mcap",
                   help="also record locally what is published")
    p.add_argument("--force", action="store_true", help="replace --record's file")
    p.add_argument("--wait-subscribers", type=number(int, 1), metavar="N",
                   help="start streaming once N subscribers listen to the raw topic")
    p.add_argument("--wait-timeout", type=number(float, 0), default=10.0, metavar="S")
    p.add_argument("--linger", type=number(float, 0), default=0.5, metavar="S",
                   help="seconds to stay up after the stream stops (default 0.5)")
    p.set_defaults(func=_cmd_publish)
