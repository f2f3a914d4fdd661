"""Property-based tests: round trips for every message type, and no exception from any bytes."""
from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from fingertip.protocol import (
    INT24_MAX,
    INT24_MIN,
    MAX_CHANNELS,
    MAX_ENCODED,
    Ack,
    GetInfo,
    GetStats,
    Info,
    Log,
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
    StreamDecoder,
    CobsError,
    Tare,
    cobs_decode,
    cobs_encode,
    encode,
)
from fingertip.protocol.messages import STATS_FIELDS

u8 = st.integers(0, 0xFF)
u16 = st.integers(0, 0xFFFF)
u32 = st.integers(0, 0xFFFFFFFF)
i24 = st.integers(INT24_MIN, INT24_MAX)
nchan = st.integers(1, MAX_CHANNELS)


@st.composite
def samples(draw):
    n = draw(nchan)
    return Sample(draw(u16), draw(u32), tuple(draw(st.lists(i24, min_size=n, max_size=n))),
                  draw(st.integers(0, (1 << n) - 1)), draw(st.integers(0, (1 << n) - 1)))


@st.composite
def infos(draw):
    n = draw(nchan)
    return Info(draw(u16), 1, draw(u8), (draw(u8), draw(u8), draw(u8)), draw(u32),
                draw(st.integers(0, 1)), draw(u8), n, draw(st.sampled_from([10, 80])),
                draw(st.integers(1, 255)), draw(st.sampled_from([128, 64, 32])), draw(u8),
                draw(u16), tuple(draw(st.lists(i24, min_size=n, max_size=n))))


device_messages = st.one_of(
    samples(), infos(),
    st.builds(Stats, u16, *[u32 for _ in STATS_FIELDS]),
    st.builds(Ack, u16, u16, u8),
    st.builds(Nack, u16, u16, u8, u8),
    st.builds(Log, u16, st.integers(0, 3), st.text(max_size=25))  # <= 100 UTF-8 bytes,
)
commands = st.one_of(
    st.builds(Ping, u16), st.builds(GetInfo, u16), st.builds(Start, u16),
    st.builds(Stop, u16), st.builds(ResetCounters, u16), st.builds(GetStats, u16),
    st.builds(Tare, u16, st.integers(1, 0xFFFF), st.integers(0, 256)),
    st.builds(SetRate, u16, st.sampled_from([10, 80]), st.integers(1, 255)),
    st.builds(SetGain, u16, st.sampled_from([128, 64, 32])),
    st.builds(SetPower, u16, st.integers(0, 1)),
    st.builds(lambda rid, mask, offs: SetTareOffsets(
        rid, mask, tuple(v if mask >> i & 1 else 0 for i, v in enumerate(offs))),
        u16, st.integers(1, 0xFFFF), st.lists(i24, min_size=16, max_size=16)),
)


@given(st.binary(max_size=600))
def test_cobs_round_trip(data):
    enc = cobs_encode(data)
    assert 0 not in enc
    assert bytes(cobs_decode(enc)) == data
    assert len(enc) <= len(data) + 1 + len(data) // 254


def _reference_decode(enc: bytes) -> bytes | None:
    """COBS decoding written from its definition, slow and plain: None when invalid."""
    if not enc or 0 in enc:
        return None
    out, i = bytearray(), 0
    while i < len(enc):
        code = enc[i]
        if i + code > len(enc):
            return None
        out += enc[i + 1:i + code]
        i += code
        if code != 0xFF and i < len(enc):
            out.append(0)
    return bytes(out)


@given(st.binary(max_size=600))
def test_cobs_decode_is_clean_on_any_bytes(data):
    """Any input decodes as the definition says or raises CobsError, never anything else."""
    want = _reference_decode(data)
    try:
        got = cobs_decode(data)
    except CobsError:
        got = None
    assert got == want


def test_cobs_rejections_named_in_issue():
    # An empty input and a zero inside the input are clean rejections (they used to be an
    # IndexError and an accepted frame).
    for bad in (b"", b"\x03\x11\x00", b"\x00", bytearray(b"\x02\x00")):
        try:
            cobs_decode(bad)
        except CobsError:
            continue
        raise AssertionError(f"{bytes(bad)!r} was accepted")
    dec = StreamDecoder("device")
    assert dec.feed(b"\x03\x11\x00") == []
    assert dec.stats.cobs_errors == 1 and dec.stats.frames_ok == 0


@given(st.lists(device_messages, min_size=1, max_size=20))
def test_device_messages_round_trip(msgs):
    dec = StreamDecoder("device")
    assert dec.feed(b"".join(encode(m) for m in msgs)) == msgs
    assert dec.stats.frames_ok == len(msgs) and dec.stats.errors_total == 0
    assert all(len(encode(m)) <= MAX_ENCODED + 1 for m in msgs)


@given(st.lists(commands, min_size=1, max_size=20))
def test_commands_round_trip(msgs):
    dec = StreamDecoder("host")
    assert dec.feed(b"".join(encode(m) for m in msgs)) == msgs


@given(st.lists(device_messages, min_size=1, max_size=10), st.data())
def test_chunking_does_not_matter(msgs, data):
    wire = b"".join(encode(m) for m in msgs)
    cuts = sorted(data.draw(st.lists(st.integers(0, len(wire)), max_size=12)))
    dec = StreamDecoder("device")
    out, last = [], 0
    for c in cuts + [len(wire)]:
        out += dec.feed(wire[last:c])
        last = c
    assert out == msgs


@settings(max_examples=300)
@given(st.binary(max_size=2000), st.sampled_from(["device", "host"]))
def test_arbitrary_bytes_only_count_errors(data, direction):
    dec = StreamDecoder(direction)
    out = dec.feed(data)  # must never raise
    st_ = dec.stats
    frames = data.count(0)
    assert st_.frames_ok + st_.empty_frames + st_.errors_total >= min(frames, 1) or frames == 0
    assert st_.frames_ok <= len(out)
    # Every completed frame is accounted for exactly once (an over-long run may span many).
    assert st_.frames_ok + st_.empty_frames + st_.errors_total <= frames + 1
    assert st_.bytes_in == len(data)


@given(st.lists(device_messages, min_size=1, max_size=5), st.binary(max_size=300))
def test_garbage_then_delimiter_resynchronises(msgs, garbage):
    dec = StreamDecoder("device")
    out = dec.feed(garbage + b"\x00" + b"".join(encode(m) for m in msgs))
    good = [m for m in out if m in msgs]
    assert good[-len(msgs):] == msgs
