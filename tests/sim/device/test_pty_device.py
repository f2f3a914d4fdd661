"""PtyDevice serves the virtual firmware in real time: a late wake-up must not lose samples.

When a command arrived after a conversion had fallen due, the serving loop advanced the
firmware (using up the samples' sequence numbers) and threw its output away. It showed only
under CPU load, as frames lost in test_hand_reader (2 of 3 runs with two busy loops).
"""
from __future__ import annotations

import os
import select
import time

from fingertip.protocol import Ack, Ping, Sample, Start, StreamDecoder, encode
from fingertip.sim import VirtualFirmware
from fingertip.sim.device.pty_device import PtyDevice


def _read_for(fd: int, seconds: float) -> bytes:
    out = b""
    end = time.monotonic() + seconds
    while (left := end - time.monotonic()) > 0:
        if select.select([fd], [], [], left)[0]:
            out += os.read(fd, 4096)
    return out


def test_a_command_after_a_late_wake_up_loses_no_sample():
    dev = PtyDevice(VirtualFirmware(4)).start()
    fd = os.open(dev.port, os.O_RDWR | os.O_NOCTTY)
    try:
        dec = StreamDecoder("device")
        os.write(fd, encode(Start(1)))
        msgs = dec.feed(_read_for(fd, 0.2))
        for k in range(3):
            # Holding the serving lock stands in for a loop the scheduler woke late: the
            # command comes in while conversions fall due (0.1 s = 8 at 80 Hz).
            with dev.held():
                os.write(fd, encode(Ping(100 + k)))
                time.sleep(0.1)
            msgs += dec.feed(_read_for(fd, 0.1))
        msgs += dec.feed(_read_for(fd, 0.1))
    finally:
        os.close(fd)
        dev.stop()
    assert sorted(m.request_id for m in msgs if isinstance(m, Ack))[-3:] == [100, 101, 102]
    assert sum(isinstance(m, Sample) for m in msgs) >= 40
    assert (dec.stats.seq_gaps, dec.stats.frames_lost) == (0, 0), dec.stats
