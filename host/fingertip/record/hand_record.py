"""``fingertip record --hand ... | --port P --hand-split 4x4``: every finger of a hand on its
own topics (``/fingertip/<finger>/raw``, ``wrench``, ``audio``, ``events``) of one MCAP file."""
from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading
import time
from pathlib import Path

from ..hand_args import HandSpec, hand_audio_from_args

log = logging.getLogger("fingertip")


def record_hand(args: argparse.Namespace, spec: HandSpec, force_model, out: Path) -> int:
    from ..audio import AudioError
    from ..device import FingertipError
    from ..protocol import ProtocolVersionError
    from ..transport import DeviceNotFound, TransportError
    from .recorder import Recorder, RecorderError

    try:
        audio = hand_audio_from_args(args, spec.fingers, sample_rate=args.audio_rate,
                                     dtype=args.audio_dtype)
    except (AudioError, ValueError) as e:
        log.error("%s", e)
        return 2
    hand = spec.build()
    rec = None
    try:
        hand.open()  # refuses a split that names channels the device does not have
        if args.tare:
            hand.tare(samples=args.tare)
        rec = Recorder(out, flush_interval=args.flush_interval,
                       flush_bytes=args.flush_kb * 1024, compression=args.compression,
                       overwrite=args.force, fsync=args.fsync)
        rec.start()
        for finger in hand.fingers:
            dev = hand.device(finger)
            info = {"name": finger, "port": dev.port, "serial_number": dev.serial_number,
                    "channels": list(spec.groups[finger]) if spec.groups else None}
            rec.add_device(finger, info=info, force_model=force_model)
        hand.add_callback(rec.write_frame)
        for source, names in audio:
            source.start()
            if len(names) == 1 and source.channels == 1:
                rec.record_audio(source, names[0])
            else:
                rec.record_audio_split(source, names)
        hand.start()
        for finger in hand.fingers:
            rec.write_event(finger, "start")
        return _loop(args, hand, rec, [src for src, _ in audio], out)
    except (RecorderError, AudioError, TransportError, FingertipError, DeviceNotFound,
            ProtocolVersionError, ValueError) as e:
        log.error("%s", e)
        return 2
    finally:
        for source, _ in audio:
            source.stop()
        if rec is not None:
            rec.close()
        hand.close()


def _loop(args, hand, rec, sources, out: Path) -> int:
    from ..device import FingertipError

    stop = threading.Event()
    old = None
    if threading.current_thread() is threading.main_thread():
        old = signal.signal(signal.SIGTERM, lambda *_: stop.set())
    t0 = time.monotonic()
    t_end = t0 + args.duration if args.duration else None
    print(f"recording hand ({', '.join(hand.fingers)}) to {out}"
          + (f" for {args.duration:g} s" if args.duration else " (Ctrl-C to stop)"),
          file=sys.stderr, flush=True)
    try:
        while not stop.is_set() and not rec.failed:
            now = time.monotonic()
            if t_end is not None and now >= t_end:
                break
            stop.wait(0.1 if t_end is None else max(0.0, min(0.1, t_end - now)))
    except KeyboardInterrupt:
        pass
    finally:
        if old is not None:
            signal.signal(signal.SIGTERM, old)
    elapsed = time.monotonic() - t0
    try:
        hand.stop()
    except FingertipError:
        pass
    hand.remove_callback(rec.write_frame)
    for finger in hand.fingers:
        rec.write_event(finger, "stop")
    for source in sources:   # before the recorder closes: what they captured is recorded
        source.stop()
    s = rec.close()
    per = {f: {k: s.written.get(f"/fingertip/{f}/{k}", 0)
               for k in ("raw", "wrench", "audio", "events")} for f in hand.fingers}
    for f, c in per.items():
        audio_s = s.audio_frames.get(f, 0)
        print(f"{f}: {c['raw']} frames, {c['wrench']} forces, {audio_s} audio frames in "
              f"{c['audio']} chunks, {c['events']} events", file=sys.stderr)
    drops = ", ".join(f"{k}: {v}" for k, v in sorted(s.dropped.items()))
    print(f"recorded {elapsed:.1f} s to {out}: dropped {s.dropped_total}"
          + (f" ({drops})" if drops else "") + "; "
          f"{s.bytes_written / 1e6:.2f} MB; hand queue overruns {hand.overruns}",
          file=sys.stderr)
    if rec.error is not None:
        log.error("%s", rec.error)
        return 1
    return 0
