"""CRC-16/CCITT-FALSE, the checksum of every v1 frame (docs/protocol.md, section 2.1)."""
from __future__ import annotations

import binascii

CRC_INIT = 0xFFFF


def crc16(data: bytes | bytearray | memoryview, crc: int = CRC_INIT) -> int:
    """Return the CRC-16 (poly 0x1021, MSB first, no final XOR) of ``data``.

    ``binascii.crc_hqx`` is exactly this polynomial and bit order; the project fixes the
    initial value at 0xFFFF so that leading zero bytes change the result.
    """
    return binascii.crc_hqx(data, crc)
