"""A port lost while a command is being written: the reader must not close the stream under
the writer's feet.

Under CPU load the restorer's GET_INFO was once in pyserial's write() when the reader closed
the port after a loss: pyserial raised a TypeError (its fd was None), which killed the
restorer thread, so the right device was never taken back
(test_restore.py failed 1 in 17 runs with two busy loops on two cores).
"""
from __future__ import annotations

import os
import threading
import time

import pytest

from fingertip import Fingertip, FingertipError
from fingertip.sim import VirtualFirmware
from fingertip.sim.device.pty_device import PtyDevice
from fingertip.transport import TransportError, open_serial

from .waiting import PATIENCE, wait_for


class SlowWriteStream:
    """The real pty stream whose writes take ``write_s`` (a UART draining a full buffer),
    noting whether it was closed while a write was under way."""

    def __init__(self, port: str, write_s: float) -> None:
        self._s = open_serial(port)
        self.name = port
        self.write_s = write_s
        self._writing = 0
        self.closed_mid_write = False
        self.writing = threading.Event()

    @property
    def is_open(self) -> bool:
        return self._s.is_open

    def fileno(self) -> int | None:
        return self._s.fileno()

    def read(self, max_bytes: int = 4096, timeout: float = 0.05) -> bytes:
        return self._s.read(max_bytes, timeout)

    def read_ready(self, max_bytes: int = 4096) -> bytes:
        return self._s.read_ready(max_bytes)

    def write(self, data: bytes) -> None:
        self._writing += 1
        self.writing.set()
        try:
            time.sleep(self.write_s)
            self._s.write(data)
        finally:
            self._writing -= 1
            self.writing.clear()

    def close(self) -> None:
        if self._writing:
            self.closed_mid_write = True
        self._s.close()


def test_the_port_is_not_closed_in_the_middle_of_a_write(tmp_path):
    link = tmp_path / "tty"
    streams: list[SlowWriteStream] = []

    def slow(port: str) -> SlowWriteStream:
        streams.append(SlowWriteStream(port, 0.0))
        return streams[-1]

    dev = PtyDevice(VirtualFirmware(4), link=link).start()
    ft = Fingertip(str(link), open_stream=slow, command_timeout=2.0, retries=0).open()
    try:
        streams[0].write_s = 0.4  # from now on each command spends 0.4 s in write()
        errors: list[BaseException] = []

        def ping() -> None:
            try:
                ft.ping()
            except FingertipError:
                pass  # the port went away: not answered, as expected
            except BaseException as e:  # anything else would kill a restorer
                errors.append(e)

        t = threading.Thread(target=ping)
        t.start()
        assert streams[0].writing.wait(2)
        dev.unplug()  # the reader sees the loss while the ping is still being written
        t.join(5)
        assert not t.is_alive()
        assert wait_for(lambda: ft.status == "reconnecting", PATIENCE)
        assert not errors, errors
        assert not streams[0].closed_mid_write
    finally:
        ft.close()
        dev.stop()


def test_a_write_racing_a_close_is_a_transport_error(tmp_path):
    """The window itself, in the real pyserial object: open (the is_open check passed) but
    its descriptor already gone, as another thread's close() leaves it for a moment."""
    dev = PtyDevice(VirtualFirmware(4)).start()
    try:
        s = open_serial(dev.port)
        os.close(s.serial.fd)
        s.serial.fd = None  # close() in progress on another thread: fd gone, is_open not yet
        with pytest.raises(TransportError):
            s.write(b"\x00")
        s.serial.is_open = False
    finally:
        dev.stop()


def test_missing_port_is_a_clear_error(tmp_path):
    with pytest.raises(TransportError, match="does not exist"):
        Fingertip(str(tmp_path / "nope")).open()
