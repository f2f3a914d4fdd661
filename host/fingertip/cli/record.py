"""``fingertip record | replay | export``: the command-line side of recordings.

:func:`add_parsers` adds the three subcommands to the ``fingertip`` command's subparsers.
Handlers return 0 done, or 1 when the recording failed part-way and kept what it had; an
error is raised for the command line's one mapping (2 a user error: wrong port, file,
argument; 1 a failure at run time).
``python -m fingertip.cli.record`` runs these on their own.
"""
from __future__ import annotations

import argparse
import importlib
import json
import logging
import sys
from collections.abc import Sequence
from functools import partial
from pathlib import Path

from ..badfile import reports_bad_files
from ..errors import BadArgumentError, Error, exit_code
from ..hand_args import add_hand_args, hand_spec_from_args
from .argtypes import dispatch, number

log = logging.getLogger("fingertip")


def load_force_model(spec: str):
    """``FILE.onnx`` (made by `fingertip calibrate fit`) or ``package.module:function`` ->
    the callable (counts -> (fx, fy[, fz]))."""
    if spec.lower().endswith(".onnx"):
        from ..models.force.runtime import ForceModel

        return ForceModel(spec)  # a bad file raises BadFileError (a ValueError)
    mod_name, sep, attr = spec.partition(":")
    if not sep or not mod_name or not attr:
        raise BadArgumentError(f"--force-model must be a FILE.onnx or look like "
                         f"package.module:function, not {spec!r}")
    try:
        mod = importlib.import_module(mod_name)
    except ImportError as e:
        raise BadArgumentError(f"cannot import force model module {mod_name!r}: {e}") from e
    fn = mod
    for part in attr.split("."):
        fn = getattr(fn, part, None)
        if fn is None:
            raise BadArgumentError(f"{mod_name} has no {attr!r}")
    if not callable(fn):
        raise BadArgumentError(f"{spec} is not callable")
    return fn


# --- record -------------------------------------------------------------------------------

@reports_bad_files
def _cmd_record(args: argparse.Namespace) -> int:
    """Record a fingertip (frames, forces, audio, events) into an MCAP file of ROS 2
    messages, until --duration passes or Ctrl-C."""
    from ..hand_args import hand_audio_from_args
    from ..record.schemas import check_name
    from ..record.session import RecordSettings, check_output, open_audio, record_fingertip

    out = Path(args.output)
    if getattr(args, "from_net", None):  # `fingertip record` hands --from to the network
        raise BadArgumentError(f"record --from is part of the `fingertip` command: run "
                               f"`fingertip record --from {args.from_net} ...`")
    if getattr(args, "wait_timeout", None) is not None:
        raise BadArgumentError("--wait-timeout is for record --from dds|zenoh|lsl (a device "
                               "that goes away is reported while it is gone)")
    check_name(args.name)
    onnx = bool(args.force_model) and (args.force_model.endswith(".onnx")
                                       or Path(args.force_model).is_file())
    # An ONNX model is read here, before any device is opened, so a bad file is
    # refused at once; it is checked against the fingertip once that is open.
    force_model = load_force_model(args.force_model) if args.force_model else None
    check_output(out, args.force, inputs=[f for f in (args.audio_file, args.force_model)
                                          if f and Path(f).exists()])
    spec = hand_spec_from_args(args)
    if spec is not None and (args.audio is not None or args.audio_file):
        raise BadArgumentError("a hand's microphones are given with --hand-audio")
    audio = (hand_audio_from_args(args, spec.fingers, sample_rate=args.audio_rate,
                                  dtype=args.audio_dtype) if spec is not None else
             open_audio(args.audio, args.audio_file, rate=args.audio_rate,
                        channels=args.audio_channels, dtype=args.audio_dtype))
    settings = RecordSettings(out, name=args.name, duration=args.duration, tare=args.tare,
                              flush_interval=args.flush_interval, flush_kb=args.flush_kb,
                              compression=args.compression, overwrite=args.force,
                              fsync=args.fsync)
    say = partial(print, file=sys.stderr, flush=True)
    live = spec is None and sys.stderr.isatty()
    if spec is not None:
        from ..record.hand_record import record_hand

        res = record_hand(settings, spec, audio, force_model, say=say)
    else:
        res = record_fingertip(
            settings, port=args.port, serial=args.serial, audio=audio,
            force_model=force_model, model_for=_model_check(args.force_model) if onnx
            else None, say=say,
            status=_overwrite_line if live else None)
    if live:
        print(file=sys.stderr)
    print(res.text(), file=sys.stderr)
    if res.error is not None:
        log.error("%s", res.error)
        return 1
    return 0


def _overwrite_line(text: str) -> None:
    """Progress on a terminal: each line replaces the one before."""
    print(f"\r{text}", end="", file=sys.stderr, flush=True)


def _model_check(path: str):
    """``--force-model FILE.onnx`` checked against the opened fingertip (channels, units,
    serial): the model, or a one-line refusal."""
    def model_for(ft):
        from ..models.force.force_load import ModelMismatch, force_model_for
        from ..record.session import SessionError

        try:
            return force_model_for(ft, path)
        except (ModelMismatch, FileNotFoundError, ValueError) as e:
            raise SessionError(f"--force-model refused: {e}") from e
    return model_for


# --- replay -------------------------------------------------------------------------------

@reports_bad_files
def _cmd_replay(args: argparse.Namespace) -> int:
    """Play a recording through the same frame interface as a live device and print its
    frames as `fingertip stream` does."""
    from ..record.replay import Replay
    from ..stream.text import frame_json, frame_line

    rp = Replay(args.file, args.name, speed=None if args.as_fast_as_possible else args.speed)
    n = 0
    try:
        with rp:
            rp.start()
            for f in rp.frames():
                if args.count is not None and n >= args.count:
                    break
                n += 1
                if args.json:
                    print(frame_json(f), flush=True)
                else:
                    print(frame_line(f), flush=True)
    except KeyboardInterrupt:
        pass
    except BrokenPipeError:  # `... | head`: the reader has gone, which is fine
        sys.stderr.close()
        return 0
    note = (f" (the recording was cut short: read up to its last complete chunk; "
            f"{CUT_SHORT_HINT})" if rp.recording.truncated else "")
    print(f"{n} frames replayed from {args.file}{note}", file=sys.stderr)
    return 0


# --- export -------------------------------------------------------------------------------

@reports_bad_files
def _cmd_export(args: argparse.Namespace) -> int:
    """Write a recording's frames (CSV per fingertip), audio (WAV per stream) and events
    (CSV) into a folder."""
    from ..record.export import export

    res = export(args.file, args.output, overwrite=args.force)
    for p in res.files:
        print(p)
    parts = [f"{n}: {c} frames" for n, c in res.frames.items()]
    parts += [f"{n}: {c} audio frames" + (f" ({res.audio_gap_frames[n]} lost, zero-filled)"
                                          if res.audio_gap_frames.get(n) else "")
              for n, c in res.audio_frames.items()]
    parts.append(f"{res.events} events")
    note = (f"; the recording was cut short: exported up to its last complete chunk "
            f"({CUT_SHORT_HINT})" if res.truncated else "")
    print(f"exported {args.file} to {args.output}: " + ", ".join(parts) + note,
          file=sys.stderr)
    return 0


# --- repair -------------------------------------------------------------------------------

@reports_bad_files
def _cmd_repair(args: argparse.Namespace) -> int:
    """Write a complete, indexed copy of a recording cut short (a killed recorder, a full
    disk) or damaged: every complete message is kept, what was lost is reported. Any MCAP
    reader opens the copy, including the mcap package's make_reader."""
    from ..record.repair import repair

    try:
        res = repair(args.file, args.output, overwrite=args.force)
    except OSError as e:
        if exit_code(e) == 2:  # the user's path: no such folder, no permission
            raise
        raise Error(f"cannot write {args.output or 'the copy'}: {e.strerror or e}") from e
    if args.json:
        print(json.dumps(res.as_dict()))
    print(f"repaired {res.source} -> {res.output}: {res.summary()}", file=sys.stderr)
    return 0


CUT_SHORT_HINT = "`fingertip repair FILE` writes a complete copy that any MCAP reader opens"


# --- parsers ------------------------------------------------------------------------------

def add_parsers(sub) -> None:
    """Add ``record``, ``replay`` and ``export`` to ``sub`` (from ``add_subparsers()``)."""
    r = sub.add_parser("record", help="record a fingertip (and its microphone) to MCAP",
                       description=_cmd_record.__doc__)
    g = r.add_mutually_exclusive_group(required=True)
    g.add_argument("--port", help="serial port of the fingertip, e.g. /dev/ttyACM0")
    g.add_argument("--serial", help="USB serial number of its Arduino (see `fingertip devices`)")
    g.add_argument("--from", dest="from_net", choices=("dds", "zenoh", "lsl"),
                   help="record what `fingertip publish` sends on the network (--name: "
                        "comma-separated fingertips)")
    add_hand_args(r, g)
    r.add_argument("-o", "--output", required=True, metavar="FILE.mcap",
                   help="the recording to write")
    r.add_argument("--duration", type=number(float, 0, lo_open=True), metavar="S",
                   help="stop after S seconds (default: at Ctrl-C)")
    a = r.add_mutually_exclusive_group()
    a.add_argument("--audio", metavar="DEVICE",
                   help="also record this sound card (index or part of its name)")
    a.add_argument("--audio-file", metavar="WAV",
                   help="also record this WAV/FLAC file as the microphone, in real time")
    r.add_argument("--audio-rate", type=number(float, 0, lo_open=True), default=44100.0,
                   help="sample rate for --audio (default 44100)")
    r.add_argument("--audio-channels", type=number(int, 1), default=1,
                   help="channels for --audio (default 1)")
    r.add_argument("--audio-dtype", choices=("int16", "int32", "float32"), default="int16",
                   help="sample format for --audio (int32 for 24-bit cards; default int16)")
    r.add_argument("--name", default="fingertip",
                   help="the fingertip's name in topic names /fingertip/NAME/... "
                        "(default: fingertip)")
    r.add_argument("--tare", type=number(int, 1), metavar="N", help="tare with N samples first")
    r.add_argument("--force-model", metavar="FORCE.onnx|MODULE:FUNCTION",
                   help="the ONNX file of `calibrate fit|record` (refused when its channels, "
                        "units or device serial do not match), or a Python callable counts "
                        "-> (fx, fy[, fz]) in newtons; the forces are recorded as "
                        "geometry_msgs/WrenchStamped")
    r.add_argument("--flush-interval", type=number(float, 0, lo_open=True), default=0.5,
                   metavar="S",
                   help="write the chunk in progress every S seconds (default 0.5): at most "
                        "this much is lost if the recorder is killed")
    r.add_argument("--flush-kb", type=number(int, 1), default=1024, metavar="KB",
                   help="... or when it reaches KB kilobytes (default 1024)")
    r.add_argument("--compression", choices=("zstd", "lz4", "none"), default="zstd",
                   help="chunk compression (default zstd)")
    r.add_argument("--fsync", action="store_true",
                   help="also force every flushed chunk onto the disk (against power loss)")
    r.add_argument("--force", action="store_true", help="replace FILE if it exists")
    r.add_argument("--wait-timeout", type=number(float, 0, lo_open=True), metavar="S",
                   help="with --from: end (exit 1) once a fingertip has sent nothing for S "
                        "seconds, from the start or since its last message (default: wait, "
                        "saying what is awaited every 5 s)")
    r.set_defaults(func=_cmd_record)

    p = sub.add_parser("replay", help="play a recording as if it were a live device",
                       description=_cmd_replay.__doc__)
    p.add_argument("file", metavar="FILE.mcap", help="a recording")
    s = p.add_mutually_exclusive_group()
    s.add_argument("--speed", type=number(float, 0, lo_open=True), default=1.0, metavar="X",
                   help="playback speed (default 1.0 = real time)")
    s.add_argument("--as-fast-as-possible", action="store_true",
                   help="no pacing: as fast as the frames are printed")
    p.add_argument("--name", help="which fingertip, if the file holds several")
    p.add_argument("--count", type=int, help="stop after N frames")
    p.add_argument("--json", action="store_true", help="one JSON object per frame")
    p.set_defaults(func=_cmd_replay)

    e = sub.add_parser("export", help="write a recording as CSV and WAV files",
                       description=_cmd_export.__doc__)
    e.add_argument("file", metavar="FILE.mcap", help="a recording")
    e.add_argument("-o", "--output", required=True, metavar="DIR",
                   help="folder for the files (created if needed; must be empty)")
    e.add_argument("--force", action="store_true",
                   help="write into a folder that is not empty (files of the same names "
                        "are replaced)")
    e.set_defaults(func=_cmd_export)

    rp = sub.add_parser("repair", help="make a complete, indexed copy of a recording cut "
                                       "short or damaged", description=_cmd_repair.__doc__)
    rp.add_argument("file", metavar="FILE.mcap", help="the recording to repair (not changed)")
    rp.add_argument("-o", "--output", metavar="OUT.mcap",
                    help="the copy (default: FILE.repaired.mcap beside it)")
    rp.add_argument("--force", action="store_true", help="replace OUT if it exists")
    rp.add_argument("--json", action="store_true", help="print what was kept and lost as JSON")
    rp.set_defaults(func=_cmd_repair)


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m fingertip.cli.record record|replay|export|repair ...``"""
    parser = argparse.ArgumentParser(prog="fingertip",
                                     description="Record, replay and export fingertip data.")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output")
    add_parsers(parser.add_subparsers(dest="command", metavar="COMMAND"))
    return dispatch(parser, argv)


if __name__ == "__main__":
    sys.exit(main())
