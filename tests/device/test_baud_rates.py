"""The host finds the UART rate the device runs at (1 Mbaud now, 115200 before).

A pty carries bytes whatever its rate, so a rate mismatch cannot happen on one: here a
wrapper around the real pty stream turns the device's bytes into what a UART at the wrong
rate would read (framing garbage) unless the host's rate equals the device's. The real
mismatch needs a USB serial adapter; everything else is the real stack.
"""
from __future__ import annotations

import pytest

from fingertip import CommandTimeout, Fingertip
from fingertip.device.fingertip import DEVICE_RATES
from fingertip.sim import VirtualFirmware
from fingertip.sim.device.pty_device import PtyDevice
from fingertip.transport import open_serial


class RateStream:
    """The real pty stream, read as a UART at ``host_rate`` would read a device sending at
    ``device_rate``: the right bytes, or each byte's bits smeared into garbage."""

    def __init__(self, port: str, host_rate: int, device_rate: int) -> None:
        self._s = open_serial(port)
        self.name = port
        self.match = host_rate == device_rate
        self.bytes_garbled = 0

    def read(self, max_bytes: int = 4096, timeout: float = 0.05) -> bytes:
        data = self._s.read(max_bytes, timeout)
        if self.match or not data:
            return data
        self.bytes_garbled += len(data)
        # A faster or slower receiver samples each byte's bits at the wrong times: no frame
        # survives (COBS and CRC reject it).
        return bytes((b * 37 + 11) & 0xFF | 0x01 for b in data)

    def write(self, data: bytes) -> None:
        if self.match:
            self._s.write(data)

    def close(self) -> None:
        self._s.close()

    @property
    def is_open(self) -> bool:
        return self._s.is_open


@pytest.fixture
def device(tmp_path):
    with PtyDevice(VirtualFirmware(4), link=tmp_path / "ttyFT0") as dev:
        yield dev


def open_at(device, device_rate: int, **kw) -> tuple[Fingertip, list[RateStream]]:
    streams: list[RateStream] = []

    def factory(port: str) -> RateStream:
        streams.append(RateStream(port, ft.baudrate, device_rate))
        return streams[-1]

    ft = Fingertip(str(device.link), open_stream=factory, open_timeout=1.0, **kw)
    return ft.open(), streams


def test_default_is_1_mbaud_first():
    assert DEVICE_RATES[0] == 1_000_000 and 115_200 in DEVICE_RATES


def test_current_firmware_is_found_at_once(device):
    ft, streams = open_at(device, 1_000_000)
    with ft:
        assert ft.baudrate == 1_000_000 and len(streams) == 1
        assert ft.info.channels == 4


def test_old_firmware_at_115200_is_found_after_1_mbaud_fails(device):
    ft, streams = open_at(device, 115_200)
    with ft:
        assert ft.baudrate == 115_200
        assert [s.match for s in streams] == [False, True]
        assert ft.ping() < 0.5


def test_a_fixed_rate_is_the_only_one_tried(device):
    made: list[RateStream] = []

    def factory(port: str) -> RateStream:
        made.append(RateStream(port, 500_000, 115_200))
        return made[-1]

    with pytest.raises(CommandTimeout):
        Fingertip(str(device.link), baudrate=500_000, open_stream=factory,
                  open_timeout=0.5).open()
    assert len(made) == 1
