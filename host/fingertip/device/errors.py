"""The errors a :class:`~fingertip.device.Fingertip` raises from its commands, and the checks
that turn a bad argument into an error naming the allowed range."""
from __future__ import annotations

import numbers

from ..errors import BadArgumentError, BadArgumentTypeError, DeviceError
from ..protocol import MAX_TARE_SAMPLES, ErrorCode


class FingertipError(DeviceError):
    """Base class of the errors a :class:`Fingertip` raises from its commands (a
    :class:`~fingertip.errors.DeviceError`, so a ``RuntimeError``). Exit status 2 at the
    command line: the port or device the user named cannot serve the command."""

    exit_code = 2


class CommandFailed(FingertipError):
    """The device answered NACK. ``code`` is the :class:`ErrorCode`."""

    def __init__(self, command: str, code: int) -> None:
        try:
            name = ErrorCode(code).name
        except ValueError:
            name = f"error {code}"
        super().__init__(f"{command} refused by the device: {name}")
        self.code = code


class CommandTimeout(FingertipError, TimeoutError):
    """No answer from the device in time (after the retries)."""


class NotConnected(FingertipError):
    """The device is not connected (closed, or reconnecting for longer than the timeout)."""


def check_int(name: str, value: object, lo: int, hi: int) -> int:
    """``value`` as an int if it is an integer in lo..hi, else a ValueError (TypeError for
    a non-integer) that names the allowed range."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise BadArgumentTypeError(f"{name} must be an integer in {lo}..{hi}, not {value!r}")
    v = int(value)  # type: ignore[arg-type]
    if not lo <= v <= hi:
        raise BadArgumentError(f"{name} must be in {lo}..{hi}, not {v}")
    return v


def check_tare_samples(samples: object) -> int:
    """Readings a tare averages: 1..256, or 0 to clear the offsets (the firmware's limit)."""
    return check_int("tare samples", samples, 0, MAX_TARE_SAMPLES)
