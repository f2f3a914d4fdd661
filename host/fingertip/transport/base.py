"""The small interface every byte transport implements (a serial port, a pty, a file)."""
from __future__ import annotations

from typing import Protocol, runtime_checkable

from ..errors import DeviceError


class TransportError(DeviceError, OSError):
    """The transport failed (port vanished, permission denied, ...): a
    :class:`~fingertip.errors.DeviceError` and an ``OSError``; exit status 2 (the port the
    user named)."""

    exit_code = 2


class TransportClosed(TransportError):
    """The transport was closed, by us or because the device went away."""


@runtime_checkable
class ByteStream(Protocol):
    """A bidirectional byte stream. ``read`` returns b"" on timeout, raises on loss."""

    name: str

    def read(self, max_bytes: int = 4096, timeout: float = 0.05) -> bytes: ...

    def write(self, data: bytes) -> None: ...

    def close(self) -> None: ...

    @property
    def is_open(self) -> bool: ...
