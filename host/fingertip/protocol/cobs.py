"""Consistent Overhead Byte Stuffing (docs/protocol.md, section 2.2). Pure functions.

The coding itself is the ``cobs`` package's C extension; this module only fixes the rules our
protocol adds on top of it: an empty input is not a frame, and every malformed encoding is one
:class:`CobsError` (a ``ValueError``), never another exception type.
"""
from __future__ import annotations

from cobs import cobs as _cobs


class CobsError(ValueError):
    """The bytes are not a valid COBS encoding."""


def cobs_encode(data: bytes | bytearray | memoryview) -> bytes:
    """Encode ``data`` so that it contains no 0x00 byte (the delimiter is not added).

    Where the data ends in a full 254-byte block, the firmware closes it with an empty last
    block (code 0x01) and the package does not; the shared vector file fixes the firmware's
    form, so it is added here. Both forms decode to the same bytes.
    """
    out = _cobs.encode(data)
    tail = len(data) - 1 - bytes(data).rfind(0)
    if tail and tail % 254 == 0:
        out += b"\x01"
    return out


def cobs_decode(encoded: bytes | bytearray | memoryview) -> bytes:
    """Decode one COBS block sequence (without its delimiter).

    Raises :class:`CobsError` for an empty input (the shortest encoding is one code byte), a
    zero byte anywhere in the input, or a code byte that points past the end.
    """
    if not encoded:
        raise CobsError("empty input: a COBS encoding has at least one code byte")
    try:
        return _cobs.decode(encoded)
    except _cobs.DecodeError as e:
        raise CobsError(f"invalid COBS encoding: {e}") from None
