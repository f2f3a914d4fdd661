"""Pack messages into wire bytes and unpack frames into messages. Pure: no I/O, no clock.

``encode`` turns any message into its complete wire form (COBS and the 0x00 delimiter).
``decode_frame`` turns one decoded frame (COBS already removed) into a message or raises
:class:`FrameError` naming the error kind of docs/protocol.md, section 2.3.
"""
from __future__ import annotations

import struct
from typing import Literal

from .cobs import cobs_encode
from .crc import crc16
from .messages import (
    CLASS_BY_TYPE,
    CRC_LEN,
    DEVICE_BIT,
    HEADER_LEN,
    INT24_MAX,
    INT24_MIN,
    MAX_CHANNELS,
    MAX_FRAME,
    MAX_LOG_TEXT,
    MAX_TARE_SAMPLES,
    MIN_FRAME,
    PROTOCOL_MAJOR,
    STATS_FIELDS,
    VALID_GAINS,
    VALID_RATES,
    Ack,
    ErrorCode,
    ForeignInfo,
    GetInfo,
    GetStats,
    Info,
    Log,
    Message,
    MsgType,
    Nack,
    Ping,
    ResetCounters,
    Sample,
    SetGain,
    SetPower,
    SetRate,
    SetTareOffsets,
    Start,
    Stats,
    Stop,
    Tare,
)

Direction = Literal["device", "host"]
"""Who sent the frames being decoded: ``"device"`` (the host's view) or ``"host"``."""

ERROR_KINDS = ("cobs", "too_short", "too_long", "crc", "unknown_type", "bad_payload")

_HEADER = struct.Struct("<BH")
_CRC = struct.Struct("<H")
_SAMPLE_HEAD = struct.Struct("<BHIBHH")  # header + timestamp, channels, two masks
_INFO_HEAD = struct.Struct("<BB3BIBBBBBBBH")
_STATS = struct.Struct("<10I")
_ACK = struct.Struct("<HB")
_NACK = struct.Struct("<HBB")
_TARE = struct.Struct("<HH")
_TARE_MASK = struct.Struct("<H")
_SAMPLE_VALUES_AT = _SAMPLE_HEAD.size  # 12
_SAMPLE_HEAD_PAYLOAD = _SAMPLE_HEAD.size - HEADER_LEN
_INFO_PAYLOAD = _INFO_HEAD.size
_from_bytes = int.from_bytes


class FrameError(ValueError):
    """A frame was rejected. ``kind`` is one of :data:`ERROR_KINDS`.

    For intact commands that the device must refuse, ``nack`` holds the NACK error code and
    ``request_id``/``command`` what to echo.
    """

    def __init__(self, kind: str, detail: str, *, nack: ErrorCode | None = None,
                 request_id: int = 0, command: int = 0) -> None:
        super().__init__(f"{kind}: {detail}")
        self.kind = kind
        self.detail = detail
        self.nack = nack
        self.request_id = request_id
        self.command = command


# --- encoding -----------------------------------------------------------------------------

def _i24(values: tuple[int, ...] | list[int], what: str) -> bytes:
    out = bytearray()
    for v in values:
        if not INT24_MIN <= v <= INT24_MAX:
            raise ValueError(f"{what} {v} is outside the signed 24-bit range")
        out += (v & 0xFFFFFF).to_bytes(3, "little")
    return bytes(out)


def _check_channels(n: int) -> None:
    if not 1 <= n <= MAX_CHANNELS:
        raise ValueError(f"{n} channels: a frame carries 1 to {MAX_CHANNELS}")


def _payload(msg: Message) -> bytes:
    if isinstance(msg, Sample):
        _check_channels(len(msg.values))
        limit = 1 << len(msg.values)
        if msg.timeout_mask >= limit or msg.saturation_mask >= limit:
            raise ValueError("status bits set for channels the frame does not carry")
        return (struct.pack("<IBHH", msg.timestamp_us, len(msg.values), msg.timeout_mask,
                            msg.saturation_mask) + _i24(msg.values, "value"))
    if isinstance(msg, Info):
        _check_channels(msg.channels)
        if len(msg.tare_offsets) != msg.channels:
            raise ValueError("INFO needs one tare offset per channel")
        return (_INFO_HEAD.pack(msg.protocol_major, msg.protocol_minor, *msg.firmware_version,
                                msg.build_id, msg.reason, msg.reset_cause, msg.channels,
                                msg.rate_sps, msg.decimation, msg.gain, msg.flags,
                                msg.tare_mask) + _i24(msg.tare_offsets, "tare offset"))
    if isinstance(msg, Stats):
        return _STATS.pack(*(getattr(msg, k) for k in STATS_FIELDS))
    if isinstance(msg, Ack):
        return _ACK.pack(msg.request_id, msg.command)
    if isinstance(msg, Nack):
        return _NACK.pack(msg.request_id, msg.command, msg.error)
    if isinstance(msg, Log):
        text = msg.text.encode("utf-8")
        if len(text) > MAX_LOG_TEXT:
            raise ValueError(f"log text of {len(text)} bytes: the limit is {MAX_LOG_TEXT}")
        return bytes([msg.level]) + text
    if isinstance(msg, Tare):
        return _TARE.pack(msg.channel_mask, msg.samples)
    if isinstance(msg, SetRate):
        return bytes([msg.rate_sps, msg.decimation])
    if isinstance(msg, SetGain):
        return bytes([msg.gain])
    if isinstance(msg, SetPower):
        return bytes([msg.on])
    if isinstance(msg, SetTareOffsets):
        if not 0 <= msg.channel_mask <= 0xFFFF:
            raise ValueError("channel mask must fit in 16 bits")
        chosen = [msg.offsets[i] for i in range(MAX_CHANNELS) if msg.channel_mask >> i & 1]
        return _TARE_MASK.pack(msg.channel_mask) + _i24(chosen, "tare offset")
    if isinstance(msg, (Ping, GetInfo, Start, Stop, ResetCounters, GetStats)):
        return b""
    raise TypeError(f"not a protocol message: {msg!r}")


def add_crc(body: bytes) -> bytes:
    """``body`` (header and payload) followed by its CRC: a frame, before COBS."""
    return body + _CRC.pack(crc16(body))


def raw_frame(type_: int, seq: int, payload: bytes = b"") -> bytes:
    """A frame (header, payload, CRC; before COBS) of any type byte and payload, unchecked:
    what tests and tools need to write frames that :func:`encode` refuses to make."""
    return add_crc(_HEADER.pack(type_, seq) + payload)


def seal(type_: int, seq: int, payload: bytes = b"") -> bytes:
    """Wire bytes of :func:`raw_frame` (COBS and the 0x00 delimiter added)."""
    return cobs_encode(raw_frame(type_, seq, payload)) + b"\x00"


def pack_frame(msg: Message) -> bytes:
    """The frame of ``msg`` (header, payload, CRC) before COBS."""
    seq = msg.request_id if msg.TYPE < DEVICE_BIT else msg.seq  # type: ignore[union-attr]
    if not 0 <= seq <= 0xFFFF:
        raise ValueError(f"sequence number / request id {seq} does not fit in 16 bits")
    payload = _payload(msg)
    if HEADER_LEN + len(payload) + CRC_LEN > MAX_FRAME:
        raise ValueError(f"frame of {HEADER_LEN + len(payload) + CRC_LEN} bytes exceeds "
                         f"{MAX_FRAME}")
    return raw_frame(msg.TYPE, seq, payload)


def encode(msg: Message) -> bytes:
    """The complete wire bytes of ``msg``: COBS-encoded frame and its 0x00 delimiter."""
    return cobs_encode(pack_frame(msg)) + b"\x00"


# --- decoding -----------------------------------------------------------------------------

def _bad(detail: str) -> FrameError:
    return FrameError("bad_payload", detail)


def _int24s(frame: bytes | bytearray, start: int, n: int) -> tuple[int, ...]:
    return tuple(_from_bytes(frame[i:i + 3], "little", signed=True)
                 for i in range(start, start + 3 * n, 3))


def decode_sample(frame: bytes | bytearray) -> Sample:
    """Decode a SAMPLE frame whose CRC has been checked (hot path: kept flat)."""
    n = len(frame) - CRC_LEN
    if n < _SAMPLE_VALUES_AT:
        raise _bad("SAMPLE shorter than its fixed fields")
    _, seq, ts, ch, tmask, smask = _SAMPLE_HEAD.unpack_from(frame)
    if not 0 < ch <= MAX_CHANNELS:
        raise _bad(f"SAMPLE with {ch} channels")
    if n < _SAMPLE_VALUES_AT + 3 * ch:
        raise _bad(f"SAMPLE announces {ch} channels but carries fewer")
    if (tmask | smask) >> ch:
        raise _bad("SAMPLE status bits set beyond its channel count")
    if ch == 4:  # the common case, unrolled
        f = frame
        values: tuple[int, ...] = (
            _from_bytes(f[12:15], "little", signed=True),
            _from_bytes(f[15:18], "little", signed=True),
            _from_bytes(f[18:21], "little", signed=True),
            _from_bytes(f[21:24], "little", signed=True),
        )
    else:
        values = _int24s(frame, _SAMPLE_VALUES_AT, ch)
    return Sample(seq, ts, values, tmask, smask)


def _decode_device(t: int, seq: int, frame: bytes | bytearray) -> Message:
    p = memoryview(frame)[HEADER_LEN:len(frame) - CRC_LEN]
    if t == MsgType.SAMPLE:
        return decode_sample(frame)
    if t == MsgType.INFO:
        if len(p) >= 2 and p[0] != PROTOCOL_MAJOR:
            # Only the two version bytes are frozen across majors; the rest may mean anything.
            return ForeignInfo(seq, p[0], p[1])
        if len(p) < _INFO_PAYLOAD:
            raise _bad("INFO shorter than its fixed fields")
        (major, minor, fw0, fw1, fw2, build, reason, cause, ch, rate, dec, gain, flags,
         tmask) = _INFO_HEAD.unpack_from(p)
        if not 0 < ch <= MAX_CHANNELS or len(p) < _INFO_PAYLOAD + 3 * ch:
            raise _bad(f"INFO with {ch} channels is too short or out of range")
        offsets = _int24s(p, _INFO_PAYLOAD, ch)
        return Info(seq, major, minor, (fw0, fw1, fw2), build, reason, cause, ch, rate, dec,
                    gain, flags, tmask, offsets)
    if t == MsgType.STATS:
        if len(p) < _STATS.size:
            raise _bad("STATS shorter than its fields")
        return Stats(seq, *_STATS.unpack_from(p))
    if t == MsgType.ACK:
        if len(p) < _ACK.size:
            raise _bad("ACK shorter than its fields")
        return Ack(seq, *_ACK.unpack_from(p))
    if t == MsgType.NACK:
        if len(p) < _NACK.size:
            raise _bad("NACK shorter than its fields")
        return Nack(seq, *_NACK.unpack_from(p))
    if t == MsgType.LOG:
        if len(p) < 1 or p[0] > 3:
            raise _bad("LOG without a valid level")
        # Trailing text is only ever text: a longer line from a newer device is still shown.
        return Log(seq, p[0], bytes(p[1:]).decode("utf-8", errors="replace"))
    raise FrameError("unknown_type", f"type 0x{t:02X} is not a device message")


_COMMAND_LEN = {
    MsgType.PING: 0, MsgType.GET_INFO: 0, MsgType.START: 0, MsgType.STOP: 0,
    MsgType.TARE: 4, MsgType.SET_RATE: 2, MsgType.SET_GAIN: 1, MsgType.RESET_COUNTERS: 0,
    MsgType.SET_POWER: 1, MsgType.GET_STATS: 0, MsgType.SET_TARE_OFFSETS: 2,
}


def _decode_command(t: int, rid: int, frame: bytes | bytearray) -> Message:
    p = bytes(frame[HEADER_LEN:len(frame) - CRC_LEN])

    def refuse(code: ErrorCode, detail: str) -> FrameError:
        return FrameError("bad_payload" if code != ErrorCode.UNKNOWN_COMMAND else
                          "unknown_type", detail, nack=code, request_id=rid, command=t)

    want = _COMMAND_LEN.get(t)  # type: ignore[call-overload]
    if t == MsgType.SET_TARE_OFFSETS and len(p) >= 2:
        want = 2 + 3 * bin(p[0] | p[1] << 8).count("1")
    if want is None:
        raise refuse(ErrorCode.UNKNOWN_COMMAND, f"type 0x{t:02X} is not a command")
    if len(p) != want:
        raise refuse(ErrorCode.BAD_LENGTH,
                     f"{MsgType(t).name} needs {want} payload bytes, got {len(p)}")
    if t == MsgType.TARE:
        mask, samples = _TARE.unpack(p)
        if mask == 0 or samples > MAX_TARE_SAMPLES:
            raise refuse(ErrorCode.BAD_ARGUMENT,
                         f"TARE mask 0x{mask:04X}, samples {samples} (0..{MAX_TARE_SAMPLES})")
        return Tare(rid, mask, samples)
    if t == MsgType.SET_RATE:
        if p[0] not in VALID_RATES or p[1] == 0:
            raise refuse(ErrorCode.BAD_ARGUMENT, f"SET_RATE {p[0]} SPS, decimation {p[1]}")
        return SetRate(rid, p[0], p[1])
    if t == MsgType.SET_GAIN:
        if p[0] not in VALID_GAINS:
            raise refuse(ErrorCode.BAD_ARGUMENT, f"SET_GAIN {p[0]}")
        return SetGain(rid, p[0])
    if t == MsgType.SET_POWER:
        if p[0] > 1:
            raise refuse(ErrorCode.BAD_ARGUMENT, f"SET_POWER {p[0]}")
        return SetPower(rid, p[0])
    if t == MsgType.SET_TARE_OFFSETS:
        (mask,) = _TARE_MASK.unpack_from(p)
        if mask == 0:
            raise refuse(ErrorCode.BAD_ARGUMENT, "SET_TARE_OFFSETS with channel mask 0")
        chosen = iter(_int24s(p, 2, (len(p) - 2) // 3))
        offsets = tuple(next(chosen) if mask >> i & 1 else 0 for i in range(MAX_CHANNELS))
        return SetTareOffsets(rid, mask, offsets)
    return CLASS_BY_TYPE[t](rid)


def check_frame(frame: bytes | bytearray) -> None:
    """Raise :class:`FrameError` unless ``frame`` has a valid length and CRC."""
    n = len(frame)
    if n < MIN_FRAME:
        raise FrameError("too_short", f"{n} bytes, a frame has at least {MIN_FRAME}")
    if n > MAX_FRAME:
        raise FrameError("too_long", f"{n} bytes, a frame has at most {MAX_FRAME}")
    if crc16(memoryview(frame)[:-CRC_LEN]) != frame[-2] | frame[-1] << 8:
        raise FrameError("crc", "CRC mismatch")


def decode_frame(frame: bytes | bytearray, direction: Direction = "device") -> Message:
    """Decode one frame (COBS removed, CRC included) sent by ``direction``."""
    check_frame(frame)
    t, seq = _HEADER.unpack_from(frame)
    if direction == "device":
        return _decode_device(t, seq, frame)
    if direction == "host":
        return _decode_command(t, seq, frame)
    raise ValueError(f"direction must be 'device' or 'host', not {direction!r}")
