"""Queue items as ROS 2 messages: what they carry, and bad values counted, not fatal."""
from __future__ import annotations

import numpy as np
import pytest

from fingertip import Frame
from fingertip.audio import Chunk
from fingertip.record import Recorder, Recording, TimeBase, schemas
from fingertip.record.encoding import audio_payload, encode_item, item_topic, xyz


def test_bad_values_are_counted_not_fatal(tmp_path):
    with Recorder(tmp_path / "bad.mcap") as rec:
        rec.add_device("a", force_model=lambda c: 1 / 0)
        from fingertip import Frame
        rec.write_frame("a", Frame(1, 10, 1.0, 1.0, (1, 2)))
        rec.write_frame("a", Frame(2, 20, 1.1, 1.1, (2**40, 2)))  # does not fit int32
        rec.write_frame("a", Frame(3, 30, 1.2, 1.2, (3, 2)))
        assert not rec.write_audio("a", Chunk(np.zeros((4, 1), np.float64), 0, 1.0, 1.0, 1.0))
    st = rec.stats
    assert st.written == {"/fingertip/a/raw": 2}
    assert st.encode_errors == 3  # 2 force-model failures + 1 frame
    assert [r.msg.seq for r in Recording(tmp_path / "bad.mcap").records()] == [1, 3]
    with pytest.raises(ValueError):
        Recorder(tmp_path / "x.mcap", flush_interval=0)
    with pytest.raises(ValueError):
        Recorder(tmp_path / "x.mcap", compression="gzip")


def test_a_frame_and_its_force_are_two_messages():
    tb = TimeBase(offset_ns=1_000_000_000)
    frame = Frame(7, 1234, 2.0, 2.5, (10, -20))
    failed = []
    msgs = encode_item(("raw", "index", frame), tb, force_model=lambda c: (c[0] / 10, 1.0),
                       on_model_error=lambda n, e: failed.append(n))
    assert [(m[0], m[1], m[2]) for m in msgs] == [("index", "raw", 3_000_000_000),
                                                   ("index", "wrench", 3_000_000_000)]
    assert schemas.decode_wrench(msgs[1][3]).force == (1.0, 1.0, 0.0)
    raw = schemas.decode_raw(msgs[0][3])
    assert (raw.seq, raw.device_time_us, raw.counts) == (7, 1234, (10, -20))
    msgs = encode_item(("raw", "index", frame), tb, force_model=lambda c: 1 / 0,
                       on_model_error=lambda n, e: failed.append(n))
    assert [m[1] for m in msgs] == ["raw"] and failed == ["index"]
    with pytest.raises(ValueError, match="unknown item"):
        encode_item(("nonsense", "index"), tb)


def test_topics_vectors_and_audio_payloads():
    assert item_topic(("event", "a", 0.0, "k", 0.0, "")) == "/fingertip/a/events"
    assert item_topic(("encoded", "a", "wrench", 0, b"")) == "/fingertip/a/wrench"
    assert xyz((1, 2)) == (1.0, 2.0, 0.0) and xyz((1, 2, 3)) == (1.0, 2.0, 3.0)
    with pytest.raises(ValueError, match="expected"):
        xyz((1,))
    enc, data = audio_payload(np.array([[1], [-2]], dtype=">i2"))  # big-endian in, LE out
    assert enc == schemas.AUDIO_ENCODINGS["int16"] and data == b"\x01\x00\xfe\xff"
    assert audio_payload(np.zeros(3, np.float64)) is None
