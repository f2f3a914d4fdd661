"""Our CDR codec gives exactly the bytes of mcap-ros2-support, and reads them back."""
from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st
from mcap_ros2._dynamic import generate_dynamic, serialize_dynamic

from fingertip.record import schemas as S

stamps = st.integers(0, 2**31 * S.NS - 1)
names = st.text(st.characters(codec="utf-8", exclude_categories=("Cs",)), max_size=12)
u32 = st.integers(0, 2**32 - 1)
u64 = st.integers(0, 2**64 - 1)
floats = st.floats(allow_nan=False)


def ros_stamp(ns: int) -> dict:
    sec, nsec = S.stamp_of(ns)
    return {"sec": sec, "nanosec": nsec}


def codec(schema: str):
    text = S.SCHEMAS[schema]
    return serialize_dynamic(schema, text)[schema], generate_dynamic(schema, text)[schema]


@given(stamps, names, st.integers(0, 0xFFFF), u64, stamps,
       st.lists(st.integers(-2**31, 2**31 - 1), max_size=16), st.integers(0, 0xFFFF),
       st.integers(0, 0xFFFF))
def test_strain_raw(stamp, frame_id, seq, dev_us, arrival, counts, tm, sm):
    enc, dec = codec(S.STRAIN_RAW)
    m = S.RawMsg(stamp, frame_id, seq, dev_us, arrival, tuple(counts), tm, sm)
    ref = enc({"header": {"stamp": ros_stamp(stamp), "frame_id": frame_id}, "seq": seq,
               "device_time_us": dev_us, "arrival": ros_stamp(arrival), "counts": counts,
               "timeout_mask": tm, "saturation_mask": sm})
    assert S.encode_raw(m) == ref
    assert S.decode_raw(ref) == m
    d = dec(ref)
    assert (d.seq, d.device_time_us, list(d.counts), d.header.frame_id) == \
        (seq, dev_us, counts, frame_id)


@given(stamps, names, u64, u32, st.integers(1, 8), floats, floats, u64,
       st.sampled_from(sorted(S.AUDIO_DTYPES)), st.binary(max_size=64))
def test_audio_chunk(stamp, frame_id, first, frames, channels, rate, host_rate, lost, enc_name,
                     data):
    enc, dec = codec(S.AUDIO_CHUNK)
    m = S.AudioMsg(stamp, frame_id, first, frames, channels, rate, host_rate, lost, enc_name,
                   data)
    ref = enc({"header": {"stamp": ros_stamp(stamp), "frame_id": frame_id},
               "first_index": first, "frames": frames, "channels": channels,
               "sample_rate": rate, "host_rate": host_rate, "lost_before": lost,
               "encoding": enc_name, "data": list(data)})
    assert S.encode_audio(m) == ref
    assert S.decode_audio(ref) == m
    assert bytes(dec(ref).data) == data


@given(stamps, names, st.tuples(floats, floats, floats), st.tuples(floats, floats, floats))
def test_wrench_stamped(stamp, frame_id, force, torque):
    enc, dec = codec(S.WRENCH_STAMPED)
    m = S.WrenchMsg(stamp, frame_id, force, torque)
    v = lambda x: {"x": x[0], "y": x[1], "z": x[2]}  # noqa: E731
    ref = enc({"header": {"stamp": ros_stamp(stamp), "frame_id": frame_id},
               "wrench": {"force": v(force), "torque": v(torque)}})
    assert S.encode_wrench(m) == ref
    assert S.decode_wrench(ref) == m
    assert dec(ref).wrench.force.y == force[1]


@given(stamps, names, names, floats, names)
def test_event_and_string(stamp, frame_id, kind, value, detail):
    enc, _ = codec(S.EVENT)
    m = S.EventMsg(stamp, frame_id, kind, value, detail)
    ref = enc({"header": {"stamp": ros_stamp(stamp), "frame_id": frame_id}, "kind": kind,
               "value": value, "detail": detail})
    assert S.encode_event(m) == ref
    assert S.decode_event(ref) == m
    senc, sdec = codec(S.STRING)
    assert S.encode_string(detail) == senc({"data": detail})
    assert sdec(S.encode_string(detail)).data == detail


def test_schemas_are_ros2msg_with_their_dependencies():
    for name, text in S.SCHEMAS.items():
        assert name.count("/msg/") == 1
        decoders = generate_dynamic(name, text)
        assert name in decoders
    assert "MSG: std_msgs/Header" in S.SCHEMAS[S.STRAIN_RAW]
    assert "MSG: builtin_interfaces/Time" in S.SCHEMAS[S.AUDIO_CHUNK]
    assert "MSG: geometry_msgs/Vector3" in S.SCHEMAS[S.WRENCH_STAMPED]


def test_topics_and_names():
    assert S.topic("index", "raw") == "/fingertip/index/raw"
    assert S.split_topic("/fingertip/thumb_2/audio") == ("thumb_2", "audio")
    assert S.split_topic("/other/thing") is None
    assert S.split_topic("/fingertip/index/unknown") is None
    for bad in ("", "1st", "a-b", "a/b", "in dex"):
        with pytest.raises(ValueError, match="topic"):
            S.check_name(bad)
    with pytest.raises(ValueError):
        S.topic("index", "nope")


@given(stamps, names, st.lists(st.integers(-2**23, 2**23 - 1), max_size=16),
       st.binary(max_size=9), st.sampled_from(sorted(S.AUDIO_DTYPES)))
def test_padded_encodings_are_the_plain_ones_zero_filled(stamp, frame_id, counts, data,
                                                          enc_name):
    """What DDS sends (padded to 4 bytes in the same pack) is the recorder's bytes plus
    zeros, for every frame_id length and channel count (each makes its own layout)."""
    msgs = [(S.encode_raw, S.RawMsg(stamp, frame_id, 7, 2**40 + 3, stamp // 2, tuple(counts),
                                    1, 2)),
            (S.encode_wrench, S.WrenchMsg(stamp, frame_id, (1.5, -2.0, 0.0))),
            (S.encode_audio, S.AudioMsg(stamp, frame_id, 5, len(data), 1, 44100.0, 44099.5,
                                        0, enc_name, data))]
    for encode, m in msgs:
        plain, padded = encode(m), encode(m, padded=True)
        assert len(padded) % 4 == 0 and len(padded) - len(plain) < 4
        assert padded == plain + b"\0" * (len(padded) - len(plain))
