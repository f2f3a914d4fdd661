"""The Python codec against the shared vector file (the C++ codec reads the same file)."""
from __future__ import annotations

import subprocess
import sys

import pytest

from fingertip.protocol import (
    MAX_ENCODED,
    MAX_FRAME,
    PROTOCOL_MAJOR,
    PROTOCOL_MINOR,
    RejectedCommand,
    StreamDecoder,
    cobs_decode,
    cobs_encode,
    crc16,
    decode_frame,
    encode,
    message_from_dict,
    message_to_dict,
)
from tests.conftest import ROOT, load_vectors

V = load_vectors()


def ids(items):
    return [v.get("name", str(i)) for i, v in enumerate(items)]


def test_vector_file_is_current():
    """The checked-in file equals what its generator writes today."""
    r = subprocess.run([sys.executable, str(ROOT / "tests/vectors/generate.py"), "--check"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


def test_limits_and_version_match():
    assert V["protocol"] == {"major": PROTOCOL_MAJOR, "minor": PROTOCOL_MINOR}
    assert V["limits"]["max_frame"] == MAX_FRAME
    assert V["limits"]["max_encoded"] == MAX_ENCODED


@pytest.mark.parametrize("v", V["crc"])
def test_crc(v):
    data = v["ascii"].encode() if "ascii" in v else bytes.fromhex(v["hex"])
    assert crc16(data) == v["crc"]


@pytest.mark.parametrize("v", V["cobs"])
def test_cobs(v):
    decoded, encoded = bytes.fromhex(v["decoded"]), bytes.fromhex(v["encoded"])
    assert cobs_encode(decoded) == encoded
    assert bytes(cobs_decode(encoded)) == decoded
    assert 0 not in encoded


@pytest.mark.parametrize("v", V["frames"], ids=ids(V["frames"]))
def test_valid_frame_encodes_exactly(v):
    assert encode(message_from_dict(v["message"])).hex() == v["hex"]


@pytest.mark.parametrize("v", V["frames"], ids=ids(V["frames"]))
def test_valid_frame_decodes_exactly(v):
    dec = StreamDecoder(v["direction"])
    out = dec.feed(bytes.fromhex(v["hex"]))
    assert [message_to_dict(m) for m in out] == [v["message"]]
    assert dec.stats.frames_ok == 1 and dec.stats.errors_total == 0
    # The one-frame API agrees with the stream decoder.
    frame = cobs_decode(bytes.fromhex(v["hex"])[:-1])
    assert message_to_dict(decode_frame(frame, v["direction"])) == v["message"]


def _directions(v):
    return ["device", "host"] if v["direction"] == "any" else [v["direction"]]


@pytest.mark.parametrize("v", V["invalid"], ids=ids(V["invalid"]))
def test_invalid_input_is_counted_by_kind(v):
    for direction in _directions(v):
        dec = StreamDecoder(direction)
        out = dec.feed(bytes.fromhex(v["hex"]))
        st = dec.stats
        assert st.frames_ok == 0
        if v["error"] == "empty":
            assert out == [] and st.empty_frames == 1 and st.errors_total == 0
            continue
        assert st.errors == {k: int(k == v["error"]) for k in st.errors}, (direction, st)
        rejected = [m for m in out if isinstance(m, RejectedCommand)]
        assert len(rejected) == len(out)
        if direction == "host" and "nack_error" in v:
            assert len(rejected) == 1 and rejected[0].error == v["nack_error"]
        else:
            assert rejected == []


@pytest.mark.parametrize("v", V["streams"], ids=ids(V["streams"]))
def test_stream(v):
    data = bytes.fromhex(v["hex"])
    for chunk in (len(data), 1, 7):
        dec = StreamDecoder(v["direction"])
        out = []
        for i in range(0, len(data), chunk):
            out += dec.feed(data[i:i + chunk])
        assert [message_to_dict(m) for m in out] == v["messages"], chunk
        expect = dict(v["counters"])
        errors = expect.pop("errors", {})
        for key, value in expect.items():
            assert getattr(dec.stats, key) == value, (key, chunk)
        assert dec.stats.errors == {k: errors.get(k, 0) for k in dec.stats.errors}, chunk
