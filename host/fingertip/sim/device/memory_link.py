"""A virtual fingertip on an in-memory byte stream: no pty, no file descriptors, no thread.

:class:`MemoryLink` holds a :class:`~.virtual_firmware.VirtualFirmware` and its clock (device
time follows the host's monotonic clock, times ``speed``); :meth:`MemoryLink.open` returns a
:class:`MemoryStream`, the transport layer's ``ByteStream``, which is what a
:class:`fingertip.Fingertip` reads and writes. The device runs inside the stream's calls:
``read`` advances it to the current time and returns what it sent, ``write`` hands it the
host's bytes. So a device opens in-process with the real bridge on top:

>>> link = MemoryLink(VirtualFirmware(4))                      # doctest: +SKIP
>>> with Fingertip("virtual", open_stream=link.open) as ft:   # doctest: +SKIP
...     ft.start()
"""
from __future__ import annotations

import threading
import time

from ...transport import TransportClosed
from .virtual_firmware import VirtualFirmware

MAX_WAIT_S = 0.05
"""Longest sleep inside one read, so that a close is noticed soon."""


class MemoryLink:
    """The device end: a virtual firmware booted at creation, with its own clock.

    ``speed``: device seconds per host second. Bytes the device sends while no stream is
    open are lost (counted in ``bytes_dropped``), as they are on an unplugged cable.
    """

    def __init__(self, firmware: VirtualFirmware | None = None, *, speed: float = 1.0,
                 name: str = "virtual") -> None:
        self.firmware = firmware or VirtualFirmware()
        self.speed = speed
        self.name = name
        self.bytes_dropped = 0
        self._lock = threading.Lock()
        self._stream: MemoryStream | None = None
        self.reboot()

    def open(self, port: str = "") -> MemoryStream:
        """A new stream to the device (the previous one, if any, is closed): the
        ``open_stream`` factory of :class:`fingertip.Fingertip`."""
        with self._lock:
            if self._stream is not None:
                self._stream._closed = True
            self._run()  # output produced before this open is not for the new reader
            self._stream = MemoryStream(self, port or self.name)
            return self._stream

    def reboot(self) -> None:
        """Reset the device (as the reset button does); its boot output goes to the stream."""
        with self._lock:
            self._t0 = time.monotonic()
            self._deliver(self.firmware.boot())

    def device_us(self) -> int:
        return int((time.monotonic() - self._t0) * self.speed * 1e6)

    # --- with the lock held ---------------------------------------------------------------

    def _deliver(self, data: bytes) -> None:
        if not data:
            return
        s = self._stream
        if s is None or s._closed:
            self.bytes_dropped += len(data)
        else:
            s._buf += data

    def _run(self) -> None:
        self._deliver(self.firmware.advance(self.device_us()))

    def _write(self, data: bytes) -> None:
        self._run()
        self._deliver(self.firmware.receive(data))

    def _wait_s(self) -> float:
        """Host seconds until the device next does something on its own."""
        due = self.firmware.next_due_us
        if due is None:
            return MAX_WAIT_S
        return max(0.0, (due - self.device_us()) / (1e6 * self.speed))


class MemoryStream:
    """One open connection to a :class:`MemoryLink` (a transport ``ByteStream``)."""

    def __init__(self, link: MemoryLink, name: str) -> None:
        self.name = name
        self._link = link
        self._buf = bytearray()
        self._closed = False
        self._wake = threading.Event()

    @property
    def is_open(self) -> bool:
        return not self._closed

    def read(self, max_bytes: int = 4096, timeout: float = 0.05) -> bytes:
        deadline = time.monotonic() + timeout
        link = self._link
        while True:
            with link._lock:
                if self._closed:
                    raise TransportClosed(f"{self.name}: closed")
                link._run()
                if self._buf:
                    data = bytes(self._buf[:max_bytes])
                    del self._buf[:max_bytes]
                    return data
                wait = link._wait_s()
            left = deadline - time.monotonic()
            if left <= 0:
                return b""
            self._wake.wait(min(left, wait, MAX_WAIT_S))
            self._wake.clear()

    def write(self, data: bytes) -> None:
        link = self._link
        with link._lock:
            if self._closed:
                raise TransportClosed(f"{self.name}: closed")
            link._write(bytes(data))
        self._wake.set()

    def close(self) -> None:
        self._closed = True
        self._wake.set()
