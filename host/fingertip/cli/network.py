"""``fingertip publish`` and ``fingertip record --from dds|zenoh|lsl``: the command-line side
of the network transports. Handlers return 0 done, 2 a user error (one clear line)."""
from __future__ import annotations

import argparse
import contextlib
import json
import logging
import sys
import time
from typing import Any

from ..hand_args import add_hand_args, hand_audio_from_args, hand_spec_from_args
from ..network import ExtraMissing
from ..network.record_cli import Stopper, record_from
from .argtypes import number

log = logging.getLogger("fingertip")

TRANSPORTS = ("dds", "zenoh", "lsl")


def _checked_force_model(path: str, sources: list, model):
    """``--force-model FORCE.onnx`` checked against every live fingertip (channels, units,
    device serial; refused with the reason), as ``stream`` and ``record`` do. A replay's
    frames are taken as they are."""
    from ..device import Fingertip
    from ..device.finger import FingerView
    from ..models.force_load import check_model, device_serial, force_model_for

    live = [s for s in sources if isinstance(s, (Fingertip, FingerView))]
    if not live:
        return model
    model = force_model_for(live[0], path)
    for ft in live[1:]:
        for w in check_model(model, channels=ft.channels, serial=device_serial(ft),
                             gain=int(ft.info.gain)):
            log.warning("%s", w)
    return model


def _names(args: argparse.Namespace, n: int) -> list[str]:
    from ..record.schemas import check_name

    if args.name:
        names = [s.strip() for s in args.name.split(",")]
    else:
        names = ["fingertip"] if n == 1 else [f"finger{i}" for i in range(n)]
    if len(names) != n:
        raise ValueError(f"--name lists {len(names)} names for {n} fingertips")
    if len(set(names)) != n:
        raise ValueError("--name: every fingertip needs its own name")
    return [check_name(s) for s in names]


def make_transport(kind: str, args: argparse.Namespace):
    if kind == "dds":
        from ..network.dds import DdsTransport

        return DdsTransport()
    if kind == "zenoh":
        from ..network.zenoh import ZenohTransport

        return ZenohTransport(args.zenoh_connect, args.zenoh_listen)
    from ..network.lsl import LslTransport

    return LslTransport()


def _open_sources(args, stack: contextlib.ExitStack, hand=None) -> list[Any]:
    """The fingertips to publish: opened devices, virtual ones on ptys, a replay, or the
    fingers of a hand (``hand``: its HandSpec)."""
    from ..device import Fingertip, SharedReader

    if hand is not None:
        from ..network.hand import open_fingers

        return open_fingers(hand, stack)
    if args.replay:
        from ..record.replay import Replay

        rp = Replay(args.replay, args.name.split(",")[0] if args.name else None,
                    speed=args.speed, rebase=not args.sim_time)
        stack.enter_context(rp)
        return [rp]
    if args.virtual:
        from ..sim import VirtualFirmware
        from ..sim.physics import Idle, VirtualStrainSensor
        from ..sim.pty_device import PtyDevice

        ports = []
        for i in range(args.virtual):
            src = VirtualStrainSensor(args.seed + i).as_source(Idle(duration=1e9))
            dev = stack.enter_context(PtyDevice(VirtualFirmware(4, source=src)))
            ports.append(dev.port)
    else:
        ports = args.port or []
    # The feed takes frames by callback (no queue), all ports read on one thread.
    reader = SharedReader()
    stack.callback(reader.close)
    fts = [stack.enter_context(Fingertip(p, queue_size=0, reader=reader).open())
           for p in ports]
    fts += [stack.enter_context(Fingertip(serial_number=s, queue_size=0, reader=reader).open())
            for s in args.serial or []]
    return fts


def _audio_source(args):
    from ..audio import FileSource, SimulatedSource, SoundDeviceSource

    if args.audio is not None:
        if args.audio == "paired":  # the card behind the same USB hub as the fingertip
            from ..device.pairing import sound_card_for_port

            if not args.port:
                raise ValueError("--audio paired needs --port (the sound card is found "
                                 "next to it on the USB hub)")
            dev: int | str = sound_card_for_port(args.port[0])
        else:
            dev = int(args.audio) if args.audio.isdigit() else args.audio
        return SoundDeviceSource(dev, args.audio_rate, channels=1, dtype="int16")
    if args.audio_file:
        return FileSource(args.audio_file, realtime=True)
    if args.virtual_audio:
        import numpy as np

        def tone(t):
            return 0.25 * np.sin(2 * np.pi * 440.0 * t)
        return SimulatedSource(tone, args.audio_rate, dtype="int16", blocksize=441)
    return None


def _cmd_publish(args: argparse.Namespace) -> int:
    """Publish fingertips live on the network: ROS 2 topics /fingertip/NAME/raw|wrench|
    audio|events|info over DDS (default) or Zenoh, or Lab Streaming Layer outlets."""
    from ..audio import AudioError
    from ..device import FingertipError
    from ..protocol import ProtocolVersionError
    from ..record.recorder import Recorder, RecorderError, device_info
    from ..transport import DeviceNotFound, TransportError
    from ..network.feed import Feed
    from ..network.hand import hand_conflict, pump_hand_audio

    try:
        hand = hand_spec_from_args(args)
        if (why := hand_conflict(args, hand)) is not None:
            raise ValueError(why)
    except ValueError as e:
        log.error("%s", e)
        return 2
    if (args.material_model or args.shake_model) and not (
            args.audio or args.audio_file or args.virtual_audio):
        log.error("--material-model and --shake-model classify the microphone: add --audio, "
                  "--audio-file or --virtual-audio")
        return 2
    try:
        from .record import load_force_model

        force_model = load_force_model(args.force_model) if args.force_model else None
        classifiers = _load_classifiers(args)
    except (ValueError, OSError) as e:
        log.error("%s", e)
        return 2
    with contextlib.ExitStack() as stack:
        try:
            transport = make_transport(args.transport, args)
            stack.callback(transport.close)
            sources = _open_sources(args, stack, hand)
            if args.force_model and args.force_model.lower().endswith(".onnx"):
                force_model = _checked_force_model(args.force_model, sources, force_model)
            names = ([s.name for s in sources] if args.replay or hand else
                     _names(args, len(sources)))
            audio = _audio_source(args)
            hand_audio = [] if hand is None else hand_audio_from_args(
                args, names, sample_rate=args.audio_rate)
            rec = None
            if args.record:
                rec = Recorder(args.record, overwrite=args.force).start()
                stack.callback(rec.close)
        except (ExtraMissing, ValueError, LookupError, TransportError, DeviceNotFound,
                FingertipError, ProtocolVersionError, AudioError, RecorderError, OSError) as e:
            log.error("%s", e)
            return 2
        except Exception as e:  # DdsError, ZenohError, LSL: the network could not start
            log.error("%s", e)
            return 2
        timebase = rec.timebase if rec is not None else None
        if args.sim_time:
            if not args.replay:
                log.error("--sim-time goes with --replay (a live device runs on ROS time)")
                return 2
            timebase = sources[0].recording.timebase  # the recording's own stamps
        feed = Feed(transport, timebase=timebase)
        stack.callback(feed.close)
        # Publishers first, so that subscribers can find them.
        for src, name in zip(sources, names, strict=True):
            feed.add_fingertip(name, force_model, device_info(src, name))
        _serve_services(args, transport, feed, rec, sources, names)
        if audio is not None and hasattr(transport, "declare_audio"):
            from ..record.schemas import AUDIO_ENCODINGS

            transport.declare_audio(names[0], audio.sample_rate, audio.channels,
                                    AUDIO_ENCODINGS[audio.dtype.name])
        _wait_subscribers(args, transport)
        for src, name in zip(sources, names, strict=True):
            feed.attach(src, name, force_model)
            if rec is not None:
                rec.attach(src, name, force_model=force_model)
        if args.replay:
            _replay_extras(args, sources[0], names[0], feed, transport, force_model)
        try:
            for src, name in zip(sources, names, strict=True):
                if args.tare and hasattr(src, "tare"):
                    offsets = src.tare(samples=args.tare)
                    _event(feed, rec, name, "tare", float(args.tare), json.dumps(list(offsets)))
            if audio is not None:
                feed.pump_audio(audio, names[0], also=_audio_consumers(
                    feed, rec, names[0], classifiers, audio.sample_rate))
            pump_hand_audio(feed, transport, hand_audio, also=_audio_consumers(
                feed, rec, "", [], args.audio_rate))
            for src, name in zip(sources, names, strict=True):
                src.start()
                if not args.replay:  # a replay publishes the events it recorded
                    _event(feed, rec, name, "start")
        except (FingertipError, AudioError) as e:
            log.error("%s", e)
            return 2
        print(f"publishing {', '.join(names)} over {args.transport}"
              + (f" for {args.duration:g} s" if args.duration else " (Ctrl-C to stop)"),
              file=sys.stderr, flush=True)
        stopper = Stopper(args.duration)
        reconnects = {n: getattr(s.stats, "reconnects", 0)
                      for s, n in zip(sources, names, strict=True)}
        while stopper.wait():
            if args.replay and sources[0].ended:
                break
            for src, name in zip(sources, names, strict=True):
                r = getattr(src.stats, "reconnects", 0)
                if r != reconnects[name]:
                    reconnects[name] = r
                    _event(feed, rec, name, "reconnect", float(r))
        for src, name in zip(sources, names, strict=True):
            with contextlib.suppress(FingertipError):
                src.stop()
            if not args.replay:
                _event(feed, rec, name, "stop")
        for a in [audio] + [src for src, _ in hand_audio]:
            if a is not None:
                a.stop()
        feed.close()
        time.sleep(args.linger)  # reliable messages still in flight reach their readers
        _summary(feed, transport)
    return 0


def _replay_extras(args, rp, name: str, feed, transport, force_model) -> None:
    """A replay also publishes its recorded forces (unless a force model recomputes them),
    events and audio; with --sim-time, /clock follows the recording's time."""
    if force_model is None:
        rp.add_wrench_callback(lambda w: feed.wrench(name, w.host_time, w.force, w.torque))
    rp.add_event_callback(lambda e: feed.event(name, e.kind, e.value, host_time=e.time,
                                               detail=e.detail))
    from ..record.reader import RecordingError

    try:
        audio = rp.audio()
    except RecordingError:  # a recording without audio
        audio = None
    if audio is not None:
        feed.pump_audio(audio, name)
    if args.sim_time:
        clock = getattr(transport, "publish_clock", None)
        if clock is None:
            log.warning("--sim-time: this transport has no /clock; stamps are the "
                        "recording's")
        else:
            rp.add_callback(lambda f: clock(feed.timebase.to_ns(f.host_time)))


def _load_classifiers(args) -> list[tuple[str, Any]]:
    """``(kind, VibrationClassifier)`` for --material-model and --shake-model."""
    out = []
    for kind, path in (("material", args.material_model), ("shake", args.shake_model)):
        if path:
            from ..models.classify import VibrationClassifier

            out.append((kind, VibrationClassifier(path, kind=kind)))
    return out


def _audio_consumers(feed, rec, name: str, classifiers, sample_rate: float):
    """What else each audio chunk feeds: the local recording, the classifiers (whose
    predictions are published as ``material`` / ``shake`` events)."""
    from ..models.classify import to_float

    lives = [(kind, clf.live(sample_rate)) for kind, clf in classifiers]
    if rec is None and not lives:
        return None

    def consume(_name: str, chunk) -> None:
        if rec is not None:
            rec.write_audio(_name, chunk)
        if not lives:
            return
        x = to_float(chunk.samples[:, 0])
        for kind, live in lives:
            for p in live.feed(x, chunk.first_index, chunk):
                _prediction_event(feed, rec, name, kind, p)
    return consume


def _prediction_event(feed, rec, name: str, kind: str, p) -> None:
    """A classifier's prediction: value = its probability, detail = the prediction (JSON)."""
    detail = json.dumps(p.to_dict())
    t = p.host_time if p.host_time is not None else time.monotonic()
    if kind == "shake":
        feed.event(name, "shake", p.probability, host_time=t, detail=detail)
    else:
        feed.event(name, "material", p.probability, host_time=t, detail=detail)
    if rec is not None:
        rec.write_event(name, kind, p.probability, host_time=t, detail=detail)


def _event(feed, rec, name: str, kind: str, value: float = 0.0, detail: str = "") -> None:
    """An event on the network and, when recording locally too, in the file (same time)."""
    t = time.monotonic()
    feed.event(name, kind, value, host_time=t, detail=detail)
    if rec is not None:
        rec.write_event(name, kind, value, host_time=t, detail=detail)


def _serve_services(args, transport, feed, rec, sources, names) -> None:
    """Tare services, unless --read-only (then nothing on the network changes the device)."""
    if args.read_only or not hasattr(transport, "serve_tare"):
        return
    for src, name in zip(sources, names, strict=True):
        if not hasattr(src, "tare"):
            continue  # a replay has nothing to tare

        def tare(_src=src, _name=name) -> tuple[bool, str]:
            offsets = _src.tare(samples=args.service_tare_samples)
            _event(feed, rec, _name, "tare", float(args.service_tare_samples),
                   json.dumps(list(offsets)))
            return True, "tare offsets: " + ", ".join(map(str, offsets))
        transport.serve_tare(name, tare)


def _wait_subscribers(args, transport) -> None:
    if not args.wait_subscribers:
        return
    wait = getattr(transport, "wait_subscribers", None)
    if wait is None:
        return
    if not wait(args.wait_subscribers, timeout=args.wait_timeout):
        log.warning("only some of the %d subscribers expected came within %g s: publishing "
                    "anyway", args.wait_subscribers, args.wait_timeout)


def _summary(feed, transport) -> None:
    pub = sum(feed.published.values())
    errs = dict(feed.errors)
    parts = ", ".join(f"{k} {v}" for k, v in sorted(feed.published.items()))
    line = f"published {pub} messages ({parts})"
    if errs:
        line += f"; errors {errs}"
    for service, st in getattr(transport, "services", {}).items():
        line += (f"; {service}: {st.requests} requests, {st.answered} answered, "
                 f"{st.refused} refused {st.reasons or ''}")
    print(line, file=sys.stderr, flush=True)


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
            return record_from(args) if args.from_net else local(args)
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
