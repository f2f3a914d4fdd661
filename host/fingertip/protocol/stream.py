"""Streaming decoder: bytes in, messages out, every loss counted. Pure: no I/O, no clock.

Feed it chunks of any size as they arrive from a port, a file or a simulator; it returns the
messages completed by each chunk. Damage never raises: the damaged frame is dropped, its
error kind is counted, and decoding resumes at the next 0x00 delimiter.
"""
from __future__ import annotations

from dataclasses import dataclass, fields

from .cobs import CobsError, cobs_decode
from .codec import ERROR_KINDS, Direction, FrameError, decode_frame, decode_sample
from .crc import crc16
from .messages import (
    CRC_LEN,
    MAX_ENCODED,
    MIN_FRAME,
    Info,
    Message,
    MsgType,
    RejectedCommand,
)

_SAMPLE = int(MsgType.SAMPLE)

COUNTER_OF_KIND = {**{k: k for k in ERROR_KINDS}, "cobs": "cobs_errors", "crc": "crc_errors"}
"""The counter (docs/protocol.md, "Counters") that counts frames rejected for each error kind."""


@dataclass(slots=True)
class DecoderStats:
    """Counters of a :class:`StreamDecoder`. All only ever grow (until :meth:`reset`)."""

    bytes_in: int = 0
    frames_ok: int = 0
    empty_frames: int = 0
    cobs_errors: int = 0
    too_short: int = 0
    too_long: int = 0
    crc_errors: int = 0
    unknown_type: int = 0
    bad_payload: int = 0
    bytes_dropped: int = 0
    """Bytes of frames that produced no message (delimiters excluded)."""
    seq_gaps: int = 0
    """Places where the device's sequence number jumped."""
    frames_lost: int = 0
    """Frames missing according to the sequence numbers."""
    device_resets: int = 0
    """Boot messages seen after the first frame (the numbering restarted)."""

    @property
    def errors(self) -> dict[str, int]:
        """Rejected frames by error kind (:data:`ERROR_KINDS`, the vector file's words)."""
        return {k: getattr(self, COUNTER_OF_KIND[k]) for k in ERROR_KINDS}

    @property
    def errors_total(self) -> int:
        return sum(getattr(self, COUNTER_OF_KIND[k]) for k in ERROR_KINDS)

    def as_dict(self) -> dict[str, int]:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def reset(self) -> None:
        for f in fields(self):
            setattr(self, f.name, 0)


class StreamDecoder:
    """Decode a byte stream sent by ``direction`` (``"device"``: the host's view).

    In the ``"host"`` direction (what a device receives) intact but malformed commands come
    out as :class:`RejectedCommand` items, so that a device can answer them with a NACK.
    """

    def __init__(self, direction: Direction = "device") -> None:
        if direction not in ("device", "host"):
            raise ValueError(f"direction must be 'device' or 'host', not {direction!r}")
        self.direction: Direction = direction
        self.stats = DecoderStats()
        self._partial = b""
        self._discarding = False  # inside an over-long frame: drop to the next delimiter
        self._last_seq: int | None = None

    def reset(self) -> None:
        """Forget any partial frame and the sequence history (counters are kept)."""
        self._partial = b""
        self._discarding = False
        self._last_seq = None

    @property
    def pending_bytes(self) -> int:
        """Bytes held for a frame whose delimiter has not arrived yet."""
        return len(self._partial)

    def feed(self, data: bytes | bytearray | memoryview) -> list[Message | RejectedCommand]:
        """Consume ``data`` and return the messages it completed, in order."""
        st = self.stats
        st.bytes_in += len(data)
        if self._partial:
            data = self._partial + bytes(data)
        elif not isinstance(data, bytes):
            data = bytes(data)
        parts = data.split(b"\x00")
        tail = parts.pop()
        out: list[Message | RejectedCommand] = []
        if self._discarding and parts:
            st.bytes_dropped += len(parts[0])
            del parts[0]
            self._discarding = False
        if self._discarding:
            st.bytes_dropped += len(tail)
            tail = b""
        elif len(tail) > MAX_ENCODED:
            st.too_long += 1
            st.bytes_dropped += len(tail)
            tail = b""
            self._discarding = True
        self._partial = tail

        device = self.direction == "device"
        for part in parts:
            n = len(part)
            if n == 0:
                st.empty_frames += 1
                continue
            if n > MAX_ENCODED:
                st.too_long += 1
                st.bytes_dropped += n
                continue
            try:
                frame = cobs_decode(part)
                # Hot path: a well-formed sample from the device, checked inline.
                if (device and len(frame) >= MIN_FRAME and frame[0] == _SAMPLE
                        and crc16(memoryview(frame)[:-CRC_LEN])
                        == frame[-2] | frame[-1] << 8):
                    msg: Message = decode_sample(frame)
                else:
                    msg = decode_frame(frame, self.direction)
            except CobsError:
                st.cobs_errors += 1
                st.bytes_dropped += n
                continue
            except FrameError as e:
                counter = COUNTER_OF_KIND[e.kind]
                setattr(st, counter, getattr(st, counter) + 1)
                st.bytes_dropped += n
                if e.nack is not None:
                    out.append(RejectedCommand(e.request_id, e.command, e.nack, e.detail))
                continue
            st.frames_ok += 1
            if device:
                self._track_seq(msg)
            out.append(msg)
        return out

    def _track_seq(self, msg: Message) -> None:
        seq = msg.seq  # type: ignore[union-attr]
        last = self._last_seq
        self._last_seq = seq
        if last is None:
            return
        if isinstance(msg, Info) and msg.is_boot:
            self.stats.device_resets += 1
            return
        gap = (seq - last - 1) & 0xFFFF
        if gap:
            self.stats.seq_gaps += 1
            self.stats.frames_lost += gap
