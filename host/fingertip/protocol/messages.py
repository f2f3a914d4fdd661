"""Messages of wire protocol v1 as plain data classes (docs/protocol.md, sections 4 and 5).

Device messages carry ``seq`` (the device's frame counter); commands carry ``request_id``
(sent in the same header field). Field names match the vector file, so a message can be
built from, and compared with, its JSON form.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields
from enum import IntEnum
from typing import Any, ClassVar

from ..errors import EXIT_USAGE, DeviceError

PROTOCOL_MAJOR = 1
PROTOCOL_MINOR = 0
MAX_FRAME = 128
MAX_ENCODED = 129
MAX_CHANNELS = 16
MAX_LOG_TEXT = 100
HEADER_LEN = 3
CRC_LEN = 2
MIN_FRAME = HEADER_LEN + CRC_LEN
INT24_MIN = -(1 << 23)
INT24_MAX = (1 << 23) - 1
DEVICE_BIT = 0x80
# INFO flags bits.
FLAG_STREAMING = 0x01
FLAG_POWERED_DOWN = 0x02
FLAG_TARE_IN_PROGRESS = 0x04


class MsgType(IntEnum):
    PING = 0x01
    GET_INFO = 0x02
    START = 0x03
    STOP = 0x04
    TARE = 0x05
    SET_RATE = 0x06
    SET_GAIN = 0x07
    RESET_COUNTERS = 0x08
    SET_POWER = 0x09
    GET_STATS = 0x0A
    SET_TARE_OFFSETS = 0x0B
    SAMPLE = 0x81
    INFO = 0x82
    STATS = 0x83
    ACK = 0x84
    NACK = 0x85
    LOG = 0x86


class ErrorCode(IntEnum):
    """NACK error codes (docs/protocol.md, section 5.1)."""

    UNKNOWN_COMMAND = 1
    BAD_LENGTH = 2
    BAD_ARGUMENT = 3
    BUSY = 4
    CHIP_TIMEOUT = 5
    POWERED_DOWN = 6


class LogLevel(IntEnum):
    DEBUG = 0
    INFO = 1
    WARNING = 2
    ERROR = 3


class InfoReason(IntEnum):
    REQUEST = 0
    BOOT = 1


VALID_RATES = (10, 80)
VALID_GAINS = (128, 64, 32)
MAX_TARE_SAMPLES = 256


@dataclass(slots=True)
class Sample:
    """One reading of every channel, with per-channel status bits."""

    TYPE: ClassVar[MsgType] = MsgType.SAMPLE
    seq: int
    timestamp_us: int
    values: tuple[int, ...]
    timeout_mask: int = 0
    saturation_mask: int = 0

    @property
    def channels(self) -> int:
        return len(self.values)

    def timed_out(self, channel: int) -> bool:
        return bool(self.timeout_mask >> channel & 1)

    def saturated(self, channel: int) -> bool:
        return bool(self.saturation_mask >> channel & 1)


@dataclass(slots=True)
class Info:
    """Who the device is and how it is set up (also the boot message, ``reason`` = 1)."""

    TYPE: ClassVar[MsgType] = MsgType.INFO
    seq: int
    protocol_major: int
    protocol_minor: int
    firmware_version: tuple[int, int, int]
    build_id: int
    reason: int
    reset_cause: int
    channels: int
    rate_sps: int
    decimation: int
    gain: int
    flags: int
    tare_mask: int
    tare_offsets: tuple[int, ...]

    @property
    def streaming(self) -> bool:
        return bool(self.flags & FLAG_STREAMING)

    @property
    def powered_down(self) -> bool:
        return bool(self.flags & FLAG_POWERED_DOWN)

    @property
    def taring(self) -> bool:
        return bool(self.flags & FLAG_TARE_IN_PROGRESS)

    @property
    def is_boot(self) -> bool:
        return self.reason == InfoReason.BOOT


@dataclass(slots=True)
class ForeignInfo:
    """An INFO from a device speaking another major version: only its version is known."""

    TYPE: ClassVar[MsgType] = MsgType.INFO
    seq: int
    protocol_major: int
    protocol_minor: int


class ProtocolVersionError(DeviceError):
    """The device speaks a major protocol version this host does not: a
    :class:`~fingertip.errors.DeviceError` (so a RuntimeError); exit status 2 at the command
    line (the device the user named needs a flash or an upgrade)."""

    exit_code = EXIT_USAGE


def require_compatible(info: Info | ForeignInfo) -> Info:
    """Return ``info`` if its major version is ours, else raise :class:`ProtocolVersionError`."""
    if isinstance(info, Info) and info.protocol_major == PROTOCOL_MAJOR:
        return info
    raise ProtocolVersionError(
        f"the device speaks wire protocol v{info.protocol_major}.{info.protocol_minor}, but "
        f"this fingertip host speaks v{PROTOCOL_MAJOR}.x: install a host release for "
        f"protocol v{info.protocol_major} (pip install -U fingertip) or flash firmware that "
        f"speaks v{PROTOCOL_MAJOR} (make firmware, then flash it)")


STATS_FIELDS = (
    "timestamp_us", "frames_sent", "read_timeouts", "saturations", "command_errors",
    "rx_overflows", "rx_crc_errors", "rx_framing_errors", "tx_overruns", "longest_loop_us",
)


@dataclass(slots=True)
class Stats:
    """The device's own counters (u32, wrapping)."""

    TYPE: ClassVar[MsgType] = MsgType.STATS
    seq: int
    timestamp_us: int
    frames_sent: int = 0
    read_timeouts: int = 0
    saturations: int = 0
    command_errors: int = 0
    rx_overflows: int = 0
    rx_crc_errors: int = 0
    rx_framing_errors: int = 0
    tx_overruns: int = 0
    longest_loop_us: int = 0


@dataclass(slots=True)
class Ack:
    TYPE: ClassVar[MsgType] = MsgType.ACK
    seq: int
    request_id: int
    command: int


@dataclass(slots=True)
class Nack:
    TYPE: ClassVar[MsgType] = MsgType.NACK
    seq: int
    request_id: int
    command: int
    error: int

    @property
    def error_name(self) -> str:
        try:
            return ErrorCode(self.error).name
        except ValueError:
            return f"error {self.error}"


@dataclass(slots=True)
class Log:
    TYPE: ClassVar[MsgType] = MsgType.LOG
    seq: int
    level: int
    text: str


@dataclass(slots=True)
class Ping:
    TYPE: ClassVar[MsgType] = MsgType.PING
    request_id: int = 0


@dataclass(slots=True)
class GetInfo:
    TYPE: ClassVar[MsgType] = MsgType.GET_INFO
    request_id: int = 0


@dataclass(slots=True)
class Start:
    TYPE: ClassVar[MsgType] = MsgType.START
    request_id: int = 0


@dataclass(slots=True)
class Stop:
    TYPE: ClassVar[MsgType] = MsgType.STOP
    request_id: int = 0


@dataclass(slots=True)
class Tare:
    TYPE: ClassVar[MsgType] = MsgType.TARE
    request_id: int = 0
    channel_mask: int = 0x000F
    samples: int = 16


@dataclass(slots=True)
class SetRate:
    TYPE: ClassVar[MsgType] = MsgType.SET_RATE
    request_id: int = 0
    rate_sps: int = 80
    decimation: int = 1


@dataclass(slots=True)
class SetGain:
    TYPE: ClassVar[MsgType] = MsgType.SET_GAIN
    request_id: int = 0
    gain: int = 128


@dataclass(slots=True)
class ResetCounters:
    TYPE: ClassVar[MsgType] = MsgType.RESET_COUNTERS
    request_id: int = 0


@dataclass(slots=True)
class SetPower:
    TYPE: ClassVar[MsgType] = MsgType.SET_POWER
    request_id: int = 0
    on: int = 1


@dataclass(slots=True)
class GetStats:
    TYPE: ClassVar[MsgType] = MsgType.GET_STATS
    request_id: int = 0


@dataclass(slots=True)
class SetTareOffsets:
    """Set the offsets of the masked channels; ``offsets`` has one entry per channel index
    (entries outside the mask are not sent and decode as 0)."""

    TYPE: ClassVar[MsgType] = MsgType.SET_TARE_OFFSETS
    request_id: int = 0
    channel_mask: int = 0
    offsets: tuple[int, ...] = (0,) * MAX_CHANNELS


@dataclass(slots=True)
class RejectedCommand:
    """An intact command frame the device must answer with a NACK (not a wire message)."""

    request_id: int
    command: int
    error: ErrorCode
    reason: str = field(default="")


DeviceMessage = Sample | Info | ForeignInfo | Stats | Ack | Nack | Log
Command = (Ping | GetInfo | Start | Stop | Tare | SetRate | SetGain | ResetCounters | SetPower
           | GetStats | SetTareOffsets)
Message = DeviceMessage | Command

DEVICE_MESSAGES: tuple[type, ...] = (Sample, Info, Stats, Ack, Nack, Log)
COMMANDS: tuple[type, ...] = (Ping, GetInfo, Start, Stop, Tare, SetRate, SetGain,
                              ResetCounters, SetPower, GetStats, SetTareOffsets)
CLASS_BY_TYPE: dict[int, type] = {cls.TYPE: cls for cls in DEVICE_MESSAGES + COMMANDS}
CLASS_BY_NAME: dict[str, type] = {cls.TYPE.name.lower(): cls for cls in CLASS_BY_TYPE.values()}


def message_name(msg: Message) -> str:
    """The lower-case type name used in logs and in the vector file (``"sample"``...)."""
    return msg.TYPE.name.lower()


def message_to_dict(msg: Message) -> dict[str, Any]:
    """A JSON-friendly dict of a message: ``{"type": name, field: value, ...}``."""
    out: dict[str, Any] = {"type": message_name(msg)}
    for f in fields(msg):
        v = getattr(msg, f.name)
        out[f.name] = list(v) if isinstance(v, tuple) else v
    return out


def message_from_dict(d: dict[str, Any]) -> Message:
    """Inverse of :func:`message_to_dict` (raises ``ValueError`` on unknown types)."""
    d = dict(d)
    name = d.pop("type")
    try:
        cls = CLASS_BY_NAME[name]
    except KeyError:
        raise ValueError(f"unknown message type {name!r}") from None
    for key in ("values", "tare_offsets", "firmware_version", "offsets"):
        if key in d:
            d[key] = tuple(d[key])
    return cls(**d)
