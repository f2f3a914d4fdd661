"""Recorder: what live code saw is in the file, readable by the standard MCAP tools."""
from __future__ import annotations

import json
import time
from collections import Counter

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap_ros2.decoder import DecoderFactory

from fingertip.record import Recorder, Recording, schemas

from .conftest import RATE, record_session


def test_standard_mcap_reader_decodes_everything(session):
    frames, chunks, st = session.frames, session.chunks, session.stats
    assert len(frames) >= RATE and len(chunks) > 50
    assert st.dropped == {} and st.encode_errors == 0
    with open(session.path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        assert summary is not None
        for sc in summary.schemas.values():
            assert sc.encoding == SchemaEncoding.ROS2 == "ros2msg"
        for ch in summary.channels.values():
            assert ch.message_encoding == MessageEncoding.CDR == "cdr"
            assert "offered_qos_profiles" in ch.metadata
        topics = {ch.topic: summary.schemas[ch.schema_id].name
                  for ch in summary.channels.values()}
        assert topics == {
            "/fingertip/index/raw": "fingertip_msgs/msg/StrainRaw",
            "/fingertip/index/wrench": "geometry_msgs/msg/WrenchStamped",
            "/fingertip/index/audio": "fingertip_msgs/msg/AudioChunk",
            "/fingertip/index/events": "fingertip_msgs/msg/Event",
            "/fingertip/index/info": "std_msgs/msg/String",
        }
        counts = {summary.channels[c].topic: n
                  for c, n in summary.statistics.channel_message_counts.items()}
        assert counts == st.written
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
    offset = int(meta["fingertip"]["monotonic_to_unix_ns"])
    with open(session.path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        got = {}
        for _, channel, message, msg in reader.iter_decoded_messages():
            got.setdefault(channel.topic, []).append((message, msg))
    raw = got["/fingertip/index/raw"]
    assert len(raw) == len(frames)
    for (message, m), f in zip(raw, frames, strict=True):
        stamp = m.header.stamp.sec * 10**9 + m.header.stamp.nanosec
        assert message.log_time == stamp
        assert abs((stamp - offset) / 1e9 - f.host_time) < 2e-9
        assert (m.seq, m.device_time_us, tuple(m.counts), m.timeout_mask,
                m.saturation_mask) == (f.seq, f.device_time_us, f.counts, f.timeout_mask,
                                       f.saturation_mask)
        assert m.header.frame_id == "index"
    wrench = got["/fingertip/index/wrench"]
    assert len(wrench) == len(frames)
    for (_, w), f in zip(wrench, frames, strict=True):
        assert w.wrench.force.x == pytest.approx(f.counts[0] * 1e-3)
        assert w.wrench.force.y == pytest.approx(f.counts[1] * 1e-4)
        assert w.wrench.force.z == 0.0
    audio = got["/fingertip/index/audio"]
    assert len(audio) == len(chunks)
    for (_, a), c in zip(audio, chunks, strict=True):
        assert (a.first_index, a.frames, a.channels, a.sample_rate, a.encoding) == \
            (c.first_index, c.frames, 1, 44100.0, "S16LE")
        samples = np.frombuffer(bytes(a.data), dtype="<i2").reshape(a.frames, a.channels)
        np.testing.assert_array_equal(samples, c.samples)
        stamp = a.header.stamp.sec * 10**9 + a.header.stamp.nanosec
        assert abs((stamp - offset) / 1e9 - c.host_time) < 2e-9
    (_, ev), = got["/fingertip/index/events"]
    assert (ev.kind, ev.value, ev.detail) == ("marker", 1.5, "hello")
    (_, info), = got["/fingertip/index/info"]
    info = json.loads(info.data)
    assert info["info"]["channels"] == 4 and info["name"] == "index"


def test_timebase_maps_stamps_back_to_monotonic(session):
    rec = Recording(session.path)
    assert rec.complete and not rec.truncated
    raws = [r.msg for r in rec.records(kinds=("raw",))]
    for m, f in zip(raws, session.frames, strict=True):
        assert abs(rec.timebase.to_monotonic(m.stamp_ns) - f.host_time) < 2e-9
        assert abs(rec.timebase.to_monotonic(m.arrival_ns) - f.arrival_time) < 2e-9
    # The offset is the wall clock minus the monotonic clock at the start.
    assert abs(rec.timebase.offset_ns / 1e9 - (time.time() - time.monotonic())) < 1.0
    assert rec.start_unix_ns <= raws[0].stamp_ns


@pytest.mark.realtime
def test_readable_while_recording_up_to_the_last_flush(device, tmp_path):
    """What a crash would leave: the file as it is on disk during the recording."""
    from fingertip import Fingertip

    path = tmp_path / "live.mcap"
    with Recorder(path, flush_interval=0.2) as rec, Fingertip(str(device.link)) as ft:
        seen = []
        ft.add_callback(seen.append)
        rec.attach(ft, "index")
        ft.start()
        time.sleep(1.5)
        n_live = len(seen)
        t = time.monotonic()
        on_disk = [r.msg for r in Recording(path).records(kinds=("raw",))]
        lag = t - Recording(path).timebase.to_monotonic(on_disk[-1].stamp_ns)
        assert n_live - len(on_disk) <= (0.2 + 0.2) * RATE
        assert lag < 0.2 + 0.2
        assert not Recording(path).complete
        ft.stop()
    assert Recording(path).complete


def test_two_fingertips_in_one_file(device, tmp_path):
    s = record_session(str(device.link), tmp_path / "two.mcap", 0.5, audio=False, model=None,
                       name="thumb")
    # A second recording of another finger into a fresh file, then both names in one file:
    with Recorder(tmp_path / "hand.mcap") as rec:
        for name in ("thumb", "index"):
            rec.add_device(name, info={"name": name})
            for f in s.frames[:10]:
                rec.write_frame(name, f)
    r = Recording(tmp_path / "hand.mcap")
    assert r.devices() == ["index", "thumb"] and r.info("index") == {"name": "index"}
    assert Counter(x.name for x in r.records(kinds=("raw",))) == {"index": 10, "thumb": 10}
    assert schemas.topic("thumb", "raw") in r.channels()
