"""Consistent Overhead Byte Stuffing (docs/protocol.md, section 2.2). Pure functions."""
from __future__ import annotations


class CobsError(ValueError):
    """The bytes are not a valid COBS encoding."""


def cobs_encode(data: bytes | bytearray) -> bytes:
    """Encode ``data`` so that it contains no 0x00 byte (the delimiter is not added)."""
    out = bytearray()
    start = 0
    n = len(data)
    while True:
        # Each block: up to 254 non-zero bytes, ended by a zero, the 254-byte limit or the end.
        zero = data.find(b"\x00", start, min(start + 254, n))
        if zero >= 0:
            out.append(zero - start + 1)
            out += data[start:zero]
            start = zero + 1
            continue
        end = min(start + 254, n)
        if end - start == 254:
            out.append(0xFF)
            out += data[start:end]
            start = end
            if start == n:
                # A full final block still needs a closing code for an empty last block.
                out.append(1)
                return bytes(out)
            continue
        out.append(end - start + 1)
        out += data[start:end]
        return bytes(out)


def cobs_decode(encoded: bytes | bytearray) -> bytearray:
    """Decode one COBS block sequence (without its delimiter).

    Raises :class:`CobsError` when a code byte is zero or points past the end.
    """
    n = len(encoded)
    buf = bytearray(encoded)
    i = 0
    # Fast path: every code byte's position becomes the zero it stands for; the first
    # code byte is dropped. Only 0xFF codes (no implied zero) need the general loop.
    while i < n:
        c = buf[i]
        if c == 0xFF or c == 0:
            return _cobs_decode_general(encoded)
        buf[i] = 0
        i += c
    if i != n:
        raise CobsError("COBS code byte points past the end of the frame")
    del buf[0]
    return buf


def _cobs_decode_general(encoded: bytes | bytearray) -> bytearray:
    out = bytearray()
    n = len(encoded)
    i = 0
    while i < n:
        c = encoded[i]
        if c == 0:
            raise CobsError("zero byte inside a COBS frame")
        j = i + c
        if j > n:
            raise CobsError("COBS code byte points past the end of the frame")
        out += encoded[i + 1:j]
        if c != 0xFF and j < n:
            out.append(0)
        i = j
    return out
