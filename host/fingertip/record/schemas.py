"""Topics, ROS 2 message definitions and a fast CDR codec for fingertip recordings.

Every schema is stored in the MCAP file as ``ros2msg`` text with its dependencies
concatenated (the format ``ros2 bag record`` writes), so any MCAP reader can decode the
messages without ROS 2 or our package installed. Messages are ROS 2 CDR (XCDR1,
little-endian, the ``cdr`` message encoding).

The encoders and decoders here are hand-written for our few fixed types: the generic
encoder of mcap-ros2-support packs arrays element by element, far too slow for audio. The
tests check that both produce and read exactly the same bytes as mcap-ros2-support.
"""
from __future__ import annotations

import re
import struct
from dataclasses import dataclass

from ..errors import BadArgumentError

SEP = "=" * 80

TIME_DEF = """\
int32 sec
uint32 nanosec"""

HEADER_DEF = """\
# Standard metadata for higher-level stamped data types.
builtin_interfaces/Time stamp
string frame_id"""

VECTOR3_DEF = """\
float64 x
float64 y
float64 z"""

WRENCH_DEF = """\
# This represents force in free space, separated into its linear and angular parts.
geometry_msgs/Vector3 force
geometry_msgs/Vector3 torque"""

WRENCH_STAMPED_DEF = """\
# A wrench with reference coordinate frame and timestamp
std_msgs/Header header
geometry_msgs/Wrench wrench"""

STRING_DEF = "string data"

STRAIN_RAW_DEF = """\
# One frame of a fingertip's strain gauges: raw HX711 counts (tare offsets already
# subtracted by the device), as the device sent it.
# header.stamp: when the chips signalled the reading ready (device time mapped to host time)
# header.frame_id: the fingertip's name
std_msgs/Header header
uint32 seq                       # device frame sequence number
uint64 device_time_us            # device clock in microseconds, unwrapped (no 32-bit wrap)
builtin_interfaces/Time arrival  # host time at which the frame's last byte was read
int32[] counts                   # one per channel
uint16 timeout_mask              # bit i set: channel i timed out (its count is not valid)
uint16 saturation_mask           # bit i set: channel i saturated"""

AUDIO_CHUNK_DEF = """\
# Consecutive frames of a contact-microphone (piezo) stream, sample-exact.
# header.stamp: host time at which the first frame was digitised
# header.frame_id: the fingertip's name
std_msgs/Header header
uint64 first_index      # absolute index of the first frame since the stream started
uint32 frames           # frames in this chunk
uint32 channels
float64 sample_rate     # nominal frames per second
float64 host_rate       # frames per host second (sample_rate corrected for clock drift)
uint64 lost_before      # frames lost just before this chunk (ring-buffer overrun)
string encoding         # S16LE, S32LE (24-bit cards: low byte zero) or F32LE
uint8[] data            # interleaved little-endian samples: frames x channels"""

EVENT_DEF = """\
# Something that happened at a moment: a contact, a release, a rim or edge crossing, a
# tare, a reconnect, a user marker.
# header.stamp: when it happened; header.frame_id: the fingertip's name
std_msgs/Header header
string kind             # contact_make, contact_break, vibration_onset, tare, start, stop...
float64 value           # its magnitude (newtons, counts, a score...); 0 when it has none
string detail           # free text or JSON; may be empty"""


def _concat(top: str, *deps: tuple[str, str]) -> str:
    parts = [top]
    for name, text in deps:
        parts.append(f"{SEP}\nMSG: {name}\n{text}")
    return "\n".join(parts) + "\n"


_HEADER_DEPS = (("std_msgs/Header", HEADER_DEF), ("builtin_interfaces/Time", TIME_DEF))

STRAIN_RAW = "fingertip_msgs/msg/StrainRaw"
AUDIO_CHUNK = "fingertip_msgs/msg/AudioChunk"
EVENT = "fingertip_msgs/msg/Event"
WRENCH_STAMPED = "geometry_msgs/msg/WrenchStamped"
STRING = "std_msgs/msg/String"

SCHEMAS: dict[str, str] = {
    STRAIN_RAW: _concat(STRAIN_RAW_DEF, *_HEADER_DEPS),
    AUDIO_CHUNK: _concat(AUDIO_CHUNK_DEF, *_HEADER_DEPS),
    EVENT: _concat(EVENT_DEF, *_HEADER_DEPS),
    WRENCH_STAMPED: _concat(WRENCH_STAMPED_DEF, ("geometry_msgs/Wrench", WRENCH_DEF),
                            ("geometry_msgs/Vector3", VECTOR3_DEF), *_HEADER_DEPS),
    STRING: _concat(STRING_DEF),
}
"""Schema name -> concatenated ros2msg text, as stored in the MCAP Schema records."""

TOPIC_KINDS: dict[str, str] = {
    "raw": STRAIN_RAW, "wrench": WRENCH_STAMPED, "audio": AUDIO_CHUNK, "events": EVENT,
    "info": STRING,
}
"""Last part of a topic name -> its schema."""


def topic(name: str, kind: str) -> str:
    """``/fingertip/<name>/<kind>``."""
    if kind not in TOPIC_KINDS:
        raise ValueError(f"unknown topic kind {kind!r}")
    return f"/fingertip/{name}/{kind}"


def split_topic(topic_name: str) -> tuple[str, str] | None:
    """``/fingertip/<name>/<kind>`` -> ``(name, kind)``; None for other topics."""
    parts = topic_name.split("/")
    if len(parts) == 4 and parts[0] == "" and parts[1] == "fingertip" and parts[3] in TOPIC_KINDS:
        return parts[2], parts[3]
    return None


def check_name(name: str) -> str:
    """A fingertip name must make a valid ROS 2 topic segment."""
    # ASCII only: str.isalpha() takes "í", which DDS refuses (BAD_PARAMETER) deep inside
    if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name):
        raise BadArgumentError(f"name {name!r} cannot be part of a ROS 2 topic: use ASCII "
                               "letters, digits and underscores, starting with a letter "
                               "(e.g. index, thumb_1)")
    return name


# QoS that `ros2 bag` expects in every channel's metadata (the MCAP "ros2" profile requires
# the key): keep-last 100, reliable, volatile, no deadline/lifespan, automatic liveliness.
_INF = "    sec: 9223372036\n    nsec: 854775807\n"
OFFERED_QOS = ("- history: 1\n  depth: 100\n  reliability: 1\n  durability: 2\n"
               f"  deadline:\n{_INF}  lifespan:\n{_INF}  liveliness: 1\n"
               f"  liveliness_lease_duration:\n{_INF}  avoid_ros_namespace_conventions: false")

AUDIO_ENCODINGS = {"int16": "S16LE", "int32": "S32LE", "float32": "F32LE"}
AUDIO_DTYPES = {v: k for k, v in AUDIO_ENCODINGS.items()}

NS = 1_000_000_000


# --- CDR (XCDR1, little-endian) -----------------------------------------------------------

_CDR_LE_HEADER = b"\x00\x01\x00\x00"
_U16, _U32, _I32, _U64, _F64 = (struct.Struct(f) for f in ("<H", "<I", "<i", "<Q", "<d"))
_STAMP = struct.Struct("<iI")


class _Writer:
    __slots__ = ("buf",)

    def __init__(self) -> None:
        self.buf = bytearray(_CDR_LE_HEADER)

    def _align(self, n: int) -> None:
        pad = -(len(self.buf) - 4) % n
        if pad:
            self.buf += b"\0" * pad

    def u8(self, v: int) -> None:
        self.buf.append(v)

    def u16(self, v: int) -> None:
        self._align(2)
        self.buf += _U16.pack(v)

    def u32(self, v: int) -> None:
        self._align(4)
        self.buf += _U32.pack(v)

    def u64(self, v: int) -> None:
        self._align(8)
        self.buf += _U64.pack(v)

    def f64(self, v: float) -> None:
        self._align(8)
        self.buf += _F64.pack(v)

    def stamp(self, ns: int) -> None:
        self._align(4)
        self.buf += _STAMP.pack(*stamp_of(ns))

    def string(self, s: str) -> None:
        b = s.encode("utf-8")
        self.u32(len(b) + 1)
        self.buf += b
        self.buf += b"\0"

    def header(self, ns: int, frame_id: str) -> None:
        self.stamp(ns)
        self.string(frame_id)

    def i32_seq(self, values) -> None:
        self.u32(len(values))
        self.buf += struct.pack(f"<{len(values)}i", *values)

    def u8_seq(self, data: bytes) -> None:
        self.u32(len(data))
        self.buf += data


CdrWriter = _Writer
"""Little-endian CDR with the encapsulation header, for messages built elsewhere (the
network's ``/diagnostics``): ``header``, ``string``, ``u8``/``u16``/``u32``/``u64``, ``f64``."""


class _Reader:
    __slots__ = ("data", "pos")

    def __init__(self, data: bytes) -> None:
        if len(data) < 4 or data[1] != 1:
            raise ValueError("not little-endian CDR")
        self.data = memoryview(data)
        self.pos = 4

    def _align(self, n: int) -> None:
        self.pos += -(self.pos - 4) % n

    def u16(self) -> int:
        self._align(2)
        (v,) = _U16.unpack_from(self.data, self.pos)
        self.pos += 2
        return v

    def u32(self) -> int:
        self._align(4)
        (v,) = _U32.unpack_from(self.data, self.pos)
        self.pos += 4
        return v

    def u64(self) -> int:
        self._align(8)
        (v,) = _U64.unpack_from(self.data, self.pos)
        self.pos += 8
        return v

    def f64(self) -> float:
        self._align(8)
        (v,) = _F64.unpack_from(self.data, self.pos)
        self.pos += 8
        return v

    def stamp(self) -> int:
        self._align(4)
        sec, nsec = _STAMP.unpack_from(self.data, self.pos)
        self.pos += 8
        return sec * NS + nsec

    def string(self) -> str:
        n = self.u32()
        s = bytes(self.data[self.pos:self.pos + max(0, n - 1)]).decode("utf-8")
        self.pos += n
        return s

    def i32_seq(self) -> tuple[int, ...]:
        n = self.u32()
        v = struct.unpack_from(f"<{n}i", self.data, self.pos)
        self.pos += 4 * n
        return v

    def u8_seq(self) -> bytes:
        n = self.u32()
        b = bytes(self.data[self.pos:self.pos + n])
        if len(b) != n:
            raise ValueError("truncated CDR sequence")
        self.pos += n
        return b


# --- precompiled layouts of the hot messages ---------------------------------------------
#
# A message's CDR layout (field offsets, alignment padding) depends only on the lengths of
# its strings and, for StrainRaw, on the channel count: for one fingertip it never changes.
# So each layout is worked out once, with _Writer's alignment rule, into one struct.Struct,
# and a message is then a single pack instead of a dozen appends and a copy.

_RAW, _WRENCH, _AUDIO = "raw", "wrench", "audio"
_LAYOUTS: dict[tuple, tuple[struct.Struct, bytes, bytes]] = {}
_MAX_LAYOUTS = 512
"""Frame ids are few in a session; the bound only keeps a stream of odd names in check."""


class _Layout:
    """The struct format of a CDR message, built field by field as _Writer writes it."""

    def __init__(self) -> None:
        self.fmt = ["<4s"]  # the encapsulation header
        self.pos = 0  # offset from the end of that header, which alignment counts from

    def field(self, code: str, size: int, align: int) -> None:
        pad = -self.pos % align
        if pad:
            self.fmt.append(f"{pad}x")
        self.fmt.append(code)
        self.pos += pad + size

    def string(self, text: str) -> bytes:
        """A string as one constant blob (length prefix, UTF-8 bytes, NUL): returned, to
        be passed to ``pack``."""
        b = text.encode("utf-8")
        blob = _U32.pack(len(b) + 1) + b + b"\0"
        self.field(f"{len(blob)}s", len(blob), 4)
        return blob

    def done(self, padded: bool) -> struct.Struct:
        pad = -self.pos % 4 if padded else 0  # the 4-byte header keeps the total's phase
        if pad:
            self.fmt.append(f"{pad}x")
        return struct.Struct("".join(self.fmt))


def _layout(kind: str, frame_id: str, n: int, padded: bool, encoding: str = ""
            ) -> tuple[struct.Struct, bytes, bytes]:
    """``(struct, frame_id blob, encoding blob)`` of a message kind (see above)."""
    key = (kind, frame_id, n, padded, encoding)
    got = _LAYOUTS.get(key)
    if got is not None:
        return got
    lay = _Layout()
    lay.field("iI", 8, 4)  # header.stamp
    name = lay.string(frame_id)
    enc = b""
    if kind == _RAW:
        for code, size, align in (("I", 4, 4), ("Q", 8, 8), ("iI", 8, 4),
                                  (f"I{n}i", 4 + 4 * n, 4), ("H", 2, 2), ("H", 2, 2)):
            lay.field(code, size, align)
    elif kind == _WRENCH:
        lay.field("6d", 48, 8)
    else:  # an audio chunk up to its samples' length prefix; the samples are joined after
        for code, size, align in (("Q", 8, 8), ("I", 4, 4), ("I", 4, 4), ("d", 8, 8),
                                  ("d", 8, 8), ("Q", 8, 8)):
            lay.field(code, size, align)
        enc = lay.string(encoding)
        lay.field("I", 4, 4)
    got = (lay.done(padded), name, enc)
    if len(_LAYOUTS) >= _MAX_LAYOUTS:
        _LAYOUTS.clear()
    _LAYOUTS[key] = got
    return got


def stamp_of(ns: int) -> tuple[int, int]:
    """Nanoseconds since the epoch -> builtin_interfaces/Time ``(sec, nanosec)``."""
    sec, nsec = divmod(int(ns), NS)
    return sec, nsec


# --- the messages as Python objects -------------------------------------------------------

@dataclass(frozen=True, slots=True)
class RawMsg:
    stamp_ns: int
    frame_id: str
    seq: int
    device_time_us: int
    arrival_ns: int
    counts: tuple[int, ...]
    timeout_mask: int
    saturation_mask: int


@dataclass(frozen=True, slots=True)
class WrenchMsg:
    stamp_ns: int
    frame_id: str
    force: tuple[float, float, float]
    torque: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True, slots=True)
class AudioMsg:
    stamp_ns: int
    frame_id: str
    first_index: int
    frames: int
    channels: int
    sample_rate: float
    host_rate: float
    lost_before: int
    encoding: str
    data: bytes


@dataclass(frozen=True, slots=True)
class EventMsg:
    stamp_ns: int
    frame_id: str
    kind: str
    value: float
    detail: str = ""


def encode_raw(m: RawMsg, *, padded: bool = False) -> bytes:
    """``fingertip_msgs/StrainRaw`` as CDR; ``padded``: zero-filled to a multiple of 4
    bytes, as rmw_cyclonedds sends a sample (one pack instead of a copy afterwards)."""
    counts = m.counts
    st, name, _ = _layout(_RAW, m.frame_id, len(counts), padded)
    sec, nsec = divmod(int(m.stamp_ns), NS)
    asec, ansec = divmod(int(m.arrival_ns), NS)
    return st.pack(_CDR_LE_HEADER, sec, nsec, name, m.seq, m.device_time_us, asec, ansec,
                   len(counts), *counts, m.timeout_mask, m.saturation_mask)


def decode_raw(data: bytes) -> RawMsg:
    r = _Reader(data)
    stamp, frame_id = r.stamp(), r.string()
    return RawMsg(stamp, frame_id, r.u32(), r.u64(), r.stamp(), r.i32_seq(), r.u16(), r.u16())


def encode_wrench(m: WrenchMsg, *, padded: bool = False) -> bytes:
    """``geometry_msgs/WrenchStamped`` as CDR (``padded``: see :func:`encode_raw`)."""
    st, name, _ = _layout(_WRENCH, m.frame_id, 0, padded)
    sec, nsec = divmod(int(m.stamp_ns), NS)
    (fx, fy, fz), (tx, ty, tz) = m.force, m.torque
    return st.pack(_CDR_LE_HEADER, sec, nsec, name, float(fx), float(fy), float(fz),
                   float(tx), float(ty), float(tz))


def decode_wrench(data: bytes) -> WrenchMsg:
    r = _Reader(data)
    stamp, frame_id = r.stamp(), r.string()
    v = [r.f64() for _ in range(6)]
    return WrenchMsg(stamp, frame_id, (v[0], v[1], v[2]), (v[3], v[4], v[5]))


def encode_audio(m: AudioMsg, *, padded: bool = False) -> bytes:
    """``fingertip_msgs/AudioChunk`` as CDR (``padded``: see :func:`encode_raw`): the
    fixed fields in one pack, the samples joined once (no growing buffer to copy)."""
    st, name, enc = _layout(_AUDIO, m.frame_id, 0, False, m.encoding)
    sec, nsec = divmod(int(m.stamp_ns), NS)
    data = m.data
    head = st.pack(_CDR_LE_HEADER, sec, nsec, name, m.first_index, m.frames, m.channels,
                   m.sample_rate, m.host_rate, m.lost_before, enc, len(data))
    pad = -(len(head) + len(data)) % 4 if padded else 0
    return b"".join((head, data, b"\0" * pad))


def decode_audio(data: bytes) -> AudioMsg:
    r = _Reader(data)
    stamp, frame_id = r.stamp(), r.string()
    return AudioMsg(stamp, frame_id, r.u64(), r.u32(), r.u32(), r.f64(), r.f64(), r.u64(),
                    r.string(), r.u8_seq())


def encode_event(m: EventMsg) -> bytes:
    w = _Writer()
    w.header(m.stamp_ns, m.frame_id)
    w.string(m.kind)
    w.f64(float(m.value))
    w.string(m.detail)
    return bytes(w.buf)


def decode_event(data: bytes) -> EventMsg:
    r = _Reader(data)
    stamp, frame_id = r.stamp(), r.string()
    return EventMsg(stamp, frame_id, r.string(), r.f64(), r.string())


def encode_string(s: str) -> bytes:
    w = _Writer()
    w.string(s)
    return bytes(w.buf)


def decode_string(data: bytes) -> str:
    return _Reader(data).string()


DECODERS = {STRAIN_RAW: decode_raw, WRENCH_STAMPED: decode_wrench, AUDIO_CHUNK: decode_audio,
            EVENT: decode_event, STRING: decode_string}
"""Schema name -> decoder of our fast codec."""
