"""Codec behaviour beyond the vectors: encoder checks, versions, and the one-frame API."""
from __future__ import annotations

import pytest

from fingertip.protocol import (
    MAX_ENCODED,
    Ack,
    ErrorCode,
    ForeignInfo,
    FrameError,
    Info,
    Log,
    Nack,
    ProtocolVersionError,
    Sample,
    SetRate,
    StreamDecoder,
    Tare,
    add_crc,
    decode_frame,
    encode,
    pack_frame,
    raw_frame,
    require_compatible,
    seal,
)


def info(major=1, minor=0, channels=4):
    return Info(0, major, minor, (0, 1, 0), 1, 0, 0, channels, 80, 1, 128, 0, 0,
                (0,) * channels)


@pytest.mark.parametrize("msg, match", [
    (Sample(0, 0, ()), "channels"),
    (Sample(0, 0, (0,) * 17), "channels"),
    (Sample(0, 0, (1 << 23,)), "24-bit"),
    (Sample(0, 0, (-(1 << 23) - 1,)), "24-bit"),
    (Sample(0, 0, (0, 0), timeout_mask=4), "status bits"),
    (Sample(0x10000, 0, (0,)), "16 bits"),
    (Log(0, 1, "é" * 51), "limit"),
    (Tare(-1, 1, 1), "16 bits"),
])
def test_encoder_refuses_what_cannot_be_sent(msg, match):
    with pytest.raises(ValueError, match=match):
        encode(msg)


def test_largest_frames_fit():
    assert len(encode(Log(0, 0, "x" * 100))) <= MAX_ENCODED + 1
    assert len(encode(Sample(0, 0, (-1,) * 16))) == 64
    assert len(encode(Sample(0, 0, (-1,) * 4))) == 28  # the bandwidth table in the spec


def test_other_major_is_refused_with_a_clear_message():
    # A v2 device: only the first two INFO payload bytes are frozen, the rest is unknown.
    frame = raw_frame(0x82, 5, bytes([2, 3, 0xAA]))
    msg = decode_frame(frame, "device")
    assert msg == ForeignInfo(5, 2, 3)
    with pytest.raises(ProtocolVersionError, match=r"v2\.3.*v1\.x"):
        require_compatible(msg)
    assert require_compatible(info(minor=7)).protocol_minor == 7


def test_newer_minor_may_append_fields():
    frame = add_crc(pack_frame(info())[:-2] + b"\x01\x02\x03")
    assert decode_frame(frame) == info()


def test_command_errors_carry_what_the_nack_needs():
    frame = pack_frame(SetRate(33, 80, 1))
    bad = bytearray(frame[:-2])
    bad[3] = 20
    with pytest.raises(FrameError) as e:
        decode_frame(add_crc(bytes(bad)), "host")
    assert (e.value.kind, e.value.nack, e.value.request_id, e.value.command) == \
        ("bad_payload", ErrorCode.BAD_ARGUMENT, 33, 0x06)


def test_invalid_utf8_log_is_kept():
    (msg,) = StreamDecoder().feed(seal(0x86, 1, b"\x02ok \xff\xfe"))
    assert msg.text.startswith("ok ") and "\ufffd" in msg.text


def test_nack_names_its_error():
    assert Nack(0, 1, 5, 4).error_name == "BUSY"
    assert Nack(0, 1, 5, 99).error_name == "error 99"


def test_bad_direction():
    with pytest.raises(ValueError):
        StreamDecoder("sideways")  # type: ignore[arg-type]


def test_reset_forgets_partial_frames_but_keeps_counters():
    dec = StreamDecoder()
    wire = encode(Sample(1, 2, (3, 4, 5, 6)))
    dec.feed(wire[:10])
    assert dec.pending_bytes == 10
    dec.reset()
    assert dec.feed(wire) == [Sample(1, 2, (3, 4, 5, 6))]
    assert dec.stats.bytes_in == 10 + len(wire)


def test_seal_builds_any_frame_and_matches_encode():
    # The public seam for frames encode() refuses to make; for a valid message it agrees.
    assert seal(0x84, 7, b"\x05\x00\x01") == encode(Ack(7, 5, 1))
    assert raw_frame(0x84, 7, b"\x05\x00\x01") == pack_frame(Ack(7, 5, 1))
    assert add_crc(pack_frame(Ack(7, 5, 1))[:-2]) == pack_frame(Ack(7, 5, 1))
    with pytest.raises(FrameError) as e:
        decode_frame(raw_frame(0x7E, 3), "host")  # an unknown command, intact: NACKed
    assert (e.value.kind, e.value.nack, e.value.request_id) == \
        ("unknown_type", ErrorCode.UNKNOWN_COMMAND, 3)
    dec = StreamDecoder("device")
    assert dec.feed(seal(0x84, 1, b"\x05")) == [] and dec.stats.bad_payload == 1
