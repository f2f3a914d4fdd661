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


def test_what_the_device_sends_while_unplugged_is_lost_not_delivered_late():
    # A device that runs on while its cable is out sends into nothing. The pty kept those
    # frames and handed them to the host after the replug, 0.6 s late with their own times:
    # the host took them for a device whose clock had stopped, i.e. one that restarted.
    dev = PtyDevice(VirtualFirmware(4)).start()
    fd = os.open(dev.port, os.O_RDWR | os.O_NOCTTY)
    try:
        os.write(fd, encode(Start(1)))
        before = [m for m in StreamDecoder("device").feed(_read_for(fd, 0.2))
                  if isinstance(m, Sample)]
        os.close(fd)
        dev.unplug()
        unplugged_at = dev.device_time_s(time.monotonic())
        time.sleep(0.4)
        replugged_at = dev.device_time_s(time.monotonic())
        dev.replug(reboot=False)
        fd = os.open(dev.port, os.O_RDWR | os.O_NOCTTY)
        after = [m for m in StreamDecoder("device").feed(_read_for(fd, 0.2))
                 if isinstance(m, Sample)]
    finally:
        os.close(fd)
        dev.stop()
    assert before and after
    assert before[-1].timestamp_us * 1e-6 < unplugged_at
    # It ran on (its numbers went on through the outage) ...
    assert after[0].seq - before[-1].seq >= 0.4 * 80 - 2
    # ... and nothing it made while unplugged reached the new port.
    assert after[0].timestamp_us * 1e-6 >= replugged_at - 1 / 80
    assert dev.bytes_dropped >= 30 * 10
