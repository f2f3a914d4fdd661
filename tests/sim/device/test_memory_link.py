"""A Fingertip opened on the in-memory stream of a virtual fingertip (no pty)."""
from __future__ import annotations

import time

import pytest

from fingertip import Fingertip
from fingertip.protocol import GetInfo, Info, StreamDecoder, encode
from fingertip.sim import VirtualFirmware
from fingertip.sim.device.memory_link import MemoryLink
from fingertip.transport import ByteStream, TransportClosed


def source(t):
    return (1000 + (t // 12_500) % 7, -50_000, 0x7FFFFF, 5)


def test_the_bridge_runs_on_the_memory_stream():
    link = MemoryLink(VirtualFirmware(4, source=source))
    with Fingertip("virtual", open_stream=link.open) as ft:
        assert ft.info.channels == 4 and ft.port == "virtual"
        offsets = ft.tare(samples=8)
        assert offsets[1] == -50_000 and 1000 <= offsets[0] <= 1006
        ft.start()
        frames = [f for _, f in zip(range(24), ft.frames(timeout=1.0), strict=False)]
        assert len(frames) == 24
        assert all(f.counts[1] == 0 and f.saturation_mask == 0b0100 for f in frames)
        dts = {b.device_time_us - a.device_time_us for a, b in zip(frames, frames[1:],
                                                                    strict=False)}
        assert dts <= {12_496, 12_500, 12_504}
        assert ft.stats.crc_errors == 0 and ft.stats.frames_lost == 0
        ft.stop()
    assert link.firmware.offsets[1] == -50_000


@pytest.mark.realtime
def test_stream_contract():
    link = MemoryLink(VirtualFirmware(4))
    s = link.open("vf0")
    assert isinstance(s, ByteStream) and s.is_open and s.name == "vf0"
    s.write(encode(GetInfo(7)))
    t0 = time.monotonic()
    data = s.read(4096, timeout=1.0)
    assert time.monotonic() - t0 < 0.5  # answered at once, not at the timeout
    info = StreamDecoder().feed(data)[0]
    assert isinstance(info, Info) and not info.is_boot
    assert s.read(4096, timeout=0.05) == b""  # idle device: nothing, after the timeout
    s2 = link.open("vf1")  # a second open takes the device over
    assert not s.is_open and s2.is_open
    with pytest.raises(TransportClosed):
        s.read()
    s2.close()
    with pytest.raises(TransportClosed):
        s2.write(b"\x00")


def test_boot_output_with_no_reader_is_counted():
    link = MemoryLink(VirtualFirmware(4))
    assert link.bytes_dropped == len(VirtualFirmware(4).boot())
    s = link.open()
    link.reboot()  # the reset button: a reader sees the boot
    (info, _log) = StreamDecoder().feed(s.read(4096, timeout=0.5))
    assert isinstance(info, Info) and info.is_boot
