"""``fingertip stream --hand ... | --port P --hand-split 4x4``: the frames of every finger,
tagged with the finger's name (one line or JSON object per finger frame)."""
from __future__ import annotations

import argparse
import logging
import sys
import time

from ..device import FingertipError
from .frame_text import frame_json, frame_line
from ..hand_args import HandSpec

log = logging.getLogger("fingertip")


def apply_stream_settings(dev, args: argparse.Namespace) -> None:
    """What `stream` sets on a device before it starts: rate and decimation, gain (one
    fingertip's device or each device of a hand)."""
    if args.rate or args.decimation:
        dev.set_rate(args.rate or dev.info.rate_sps, args.decimation or 1)
    if args.gain:
        dev.set_gain(args.gain)


def stream_hand(args: argparse.Namespace, spec: HandSpec) -> int:
    hand = spec.build()
    try:
        hand.open()  # refuses a split that names channels the device does not have
    except ValueError as e:
        log.error("%s", e)
        return 2
    try:
        for dev in hand.devices:
            apply_stream_settings(dev, args)
        if args.tare:
            hand.tare(samples=args.tare)
        hand.start()
        n = 0
        t_end = (time.monotonic() + args.duration) if args.duration else None
        try:
            while (args.count is None or n < args.count) and \
                    (t_end is None or time.monotonic() < t_end):
                ff = hand.read(timeout=1.0)
                if ff is None:
                    continue
                n += 1
                f = ff.frame
                if args.json:
                    print(frame_json(f, finger=ff.finger), flush=True)
                else:
                    print(f"{ff.finger:<8} " + frame_line(f), flush=True)
        except KeyboardInterrupt:
            pass
        finally:
            try:
                hand.stop()
            except FingertipError:
                pass
        for dev in hand.devices:
            st = dev.stats
            print(f"{dev.port}: lost {st.frames_lost}, CRC errors {st.crc_errors}, COBS "
                  f"errors {st.cobs_errors}, reconnects {st.reconnects}", file=sys.stderr)
        print(f"{n} finger frames ({', '.join(hand.fingers)}); hand queue overruns "
              f"{hand.overruns}", file=sys.stderr)
    finally:
        hand.close()
    return 0
