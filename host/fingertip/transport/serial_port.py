"""A serial port (USB CDC, FTDI, or a pseudo-terminal) as a :class:`ByteStream`."""
from __future__ import annotations

import logging
import os
import select

import serial

from .base import TransportClosed, TransportError

log = logging.getLogger(__name__)

DEFAULT_BAUD = 115200


class SerialStream:
    """pyserial underneath; every pyserial or OS error becomes a :class:`TransportError`."""

    def __init__(self, port: str, baudrate: int = DEFAULT_BAUD) -> None:
        self.name = port
        self.baudrate = baudrate
        try:
            # exclusive: a second bridge on the same fingertip would steal half its bytes.
            self._ser = serial.Serial(port, baudrate, timeout=0.05, write_timeout=1.0,
                                      exclusive=True)
        except (serial.SerialException, OSError, ValueError) as e:
            raise TransportError(_explain(port, e)) from e
        # On POSIX, wait on the descriptor and take whatever has arrived in one read: one
        # wake-up per burst of bytes instead of pyserial's byte-count-driven loop.
        try:
            self._fd: int | None = self._ser.fileno()
            # One poll object for the stream's life: no fd list to build per wake-up.
            self._poll = select.poll()
            self._poll.register(self._fd, select.POLLIN)
        except (AttributeError, serial.SerialException, OSError):
            self._fd = None

    @property
    def is_open(self) -> bool:
        return self._ser.is_open

    @property
    def serial(self) -> serial.Serial:
        """The pyserial port underneath, for what this class does not wrap (its errors are
        pyserial's own, not :class:`TransportError`)."""
        return self._ser

    def fileno(self) -> int | None:
        """The descriptor a caller may wait on (selectors) before :meth:`read`, or None."""
        return self._fd if self._ser.is_open else None

    def read(self, max_bytes: int = 4096, timeout: float = 0.05) -> bytes:
        if not self._ser.is_open:
            raise TransportClosed(f"{self.name} is closed")
        if self._fd is not None:
            try:
                if not self._poll.poll(timeout * 1000.0):
                    return b""
            except (OSError, ValueError) as e:
                raise TransportClosed(f"{self.name}: {e}") from e
            return self.read_ready(max_bytes)
        try:
            if self._ser.timeout != timeout:
                self._ser.timeout = timeout
            waiting = self._ser.in_waiting
            return self._ser.read(min(max(waiting, 1), max_bytes))
        except (serial.SerialException, OSError, TypeError, AttributeError) as e:
            # TypeError/AttributeError: pyserial after the fd vanished under it.
            raise TransportClosed(f"{self.name}: {e}") from e

    def read_ready(self, max_bytes: int = 4096) -> bytes:
        """What has arrived, without waiting: for a caller that already waited on
        :meth:`fileno` (one select for several ports) and was told it is readable, so the
        second poll of :meth:`read` would only cost a system call."""
        if self._fd is None:
            return self.read(max_bytes, timeout=0)
        if not self._ser.is_open:
            raise TransportClosed(f"{self.name} is closed")
        try:
            data = os.read(self._fd, max_bytes)
        except BlockingIOError:
            return b""
        except (OSError, ValueError) as e:
            raise TransportClosed(f"{self.name}: {e}") from e
        if not data:  # readable but empty: the device is gone (USB unplugged, pty closed)
            raise TransportClosed(f"{self.name}: the device disconnected")
        return data

    def write(self, data: bytes) -> None:
        if not self._ser.is_open:
            raise TransportClosed(f"{self.name} is closed")
        try:
            self._ser.write(data)
        except (serial.SerialException, OSError, TypeError, AttributeError) as e:
            # TypeError/AttributeError: closed by another thread after the is_open check
            # (pyserial's fd is None by then), as in read().
            raise TransportClosed(f"{self.name}: {e}") from e

    def close(self) -> None:
        try:
            self._ser.close()
        except (serial.SerialException, OSError) as e:  # already gone: nothing to release
            log.debug("closing %s: %s", self.name, e)


def _explain(port: str, e: Exception) -> str:
    if not os.path.exists(port):
        return (f"serial port {port} does not exist: is the fingertip plugged in? "
                f"`fingertip devices` lists the ports found")
    if isinstance(e, OSError) and e.errno == 13 or "Permission denied" in str(e):
        return (f"no permission to open {port}: add yourself to the 'dialout' group "
                f"(sudo usermod -aG dialout $USER, then log in again)")
    if "exclusively lock" in str(e) or "busy" in str(e).lower():
        return f"{port} is in use by another program (another bridge, a serial monitor?)"
    return f"cannot open {port}: {e}"


def open_serial(port: str, baudrate: int = DEFAULT_BAUD) -> SerialStream:
    return SerialStream(port, baudrate)
