"""Wire protocol v1 (docs/protocol.md): a pure codec, bytes in and messages out.

No I/O and no clocks live here, so every layer above (transport, device, simulator) can use
it and it can be tested directly against tests/vectors/protocol_v1.json.
"""
from .cobs import CobsError, cobs_decode, cobs_encode
from .codec import (
    ERROR_KINDS,
    Direction,
    FrameError,
    add_crc,
    decode_frame,
    encode,
    pack_frame,
    raw_frame,
    seal,
)
from .crc import crc16
from .messages import (
    COMMANDS,
    DEVICE_MESSAGES,
    INT24_MAX,
    INT24_MIN,
    MAX_CHANNELS,
    MAX_ENCODED,
    MAX_FRAME,
    MAX_LOG_TEXT,
    MAX_TARE_SAMPLES,
    PROTOCOL_MAJOR,
    PROTOCOL_MINOR,
    VALID_GAINS,
    VALID_RATES,
    Ack,
    Command,
    DeviceMessage,
    ErrorCode,
    ForeignInfo,
    GetInfo,
    GetStats,
    Info,
    InfoReason,
    Log,
    LogLevel,
    Message,
    MsgType,
    Nack,
    Ping,
    ProtocolVersionError,
    RejectedCommand,
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
    message_from_dict,
    message_name,
    message_to_dict,
    require_compatible,
)
from .stream import DecoderStats, StreamDecoder

__all__ = [
    "COMMANDS", "DEVICE_MESSAGES", "ERROR_KINDS", "INT24_MAX", "INT24_MIN", "MAX_CHANNELS",
    "MAX_ENCODED", "MAX_FRAME", "MAX_LOG_TEXT", "MAX_TARE_SAMPLES", "PROTOCOL_MAJOR",
    "PROTOCOL_MINOR", "VALID_GAINS", "VALID_RATES", "Ack", "CobsError", "Command",
    "DecoderStats", "DeviceMessage", "Direction", "ErrorCode", "ForeignInfo", "FrameError",
    "GetInfo", "GetStats", "Info", "InfoReason", "Log", "LogLevel", "Message", "MsgType",
    "Nack", "Ping", "ProtocolVersionError", "RejectedCommand", "ResetCounters", "Sample",
    "SetGain", "SetPower", "SetRate", "SetTareOffsets", "Start", "Stats", "Stop",
    "StreamDecoder", "Tare",
    "add_crc", "cobs_decode", "cobs_encode", "crc16", "decode_frame", "encode",
    "message_from_dict", "message_name", "message_to_dict", "pack_frame", "raw_frame",
    "require_compatible", "seal",
]
