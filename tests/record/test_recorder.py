"""Recorder: what live code saw is in the file, readable by the standard MCAP tools."""
from __future__ import annotations

import errno
import json
import os
import threading
import time
from collections import Counter

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap_ros2.decoder import DecoderFactory

from fingertip.audio import Chunk
from fingertip.record import Recorder, RecorderError, Recording, schemas
from fingertip.record import recorder as recorder_mod

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


def test_concurrent_writers_lose_nothing(tmp_path):
    path = tmp_path / "threads.mcap"
    n_threads, n_each = 8, 2000
    with Recorder(path, queue_size=n_threads * n_each + 10) as rec:
        def work(i: int) -> None:
            for k in range(n_each):
                rec.write_event(f"f{i}", "tick", float(k), host_time=1000.0 + k * 1e-3)
        threads = [threading.Thread(target=work, args=(i,)) for i in range(n_threads)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    st = rec.stats
    assert st.dropped == {}
    assert st.written == {f"/fingertip/f{i}/events": n_each for i in range(n_threads)}
    values = {}
    for r in Recording(path).records():
        values.setdefault(r.name, []).append(r.msg.value)
    assert all(v == [float(k) for k in range(n_each)] for v in values.values())


def test_a_full_queue_drops_and_counts(tmp_path, monkeypatch):
    gate = threading.Event()
    real_handle = Recorder._handle

    def slow_handle(self, item):
        gate.wait(5)
        real_handle(self, item)

    monkeypatch.setattr(Recorder, "_handle", slow_handle)
    rec = Recorder(tmp_path / "q.mcap", queue_size=10).start()
    results = Counter(rec.write_event("a", "x", float(i)) for i in range(100))
    gate.set()
    st = rec.close()
    assert results[True] + results[False] == 100 and results[False] >= 80
    assert st.dropped["/fingertip/a/events"] == results[False]
    assert st.written["/fingertip/a/events"] == results[True]
    assert st.queue_high_water >= 9


def test_unwritable_places_are_clear_errors(tmp_path):
    ro = tmp_path / "readonly"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        if os.access(ro, os.W_OK):  # root ignores the mode: use a filesystem that refuses
            target = "/sys/fingertip-test.mcap"
        else:
            target = str(ro / "x.mcap")
        with pytest.raises(RecorderError, match="cannot create .*(Permission denied|"
                                                "Read-only)"):
            Recorder(target).start()
    finally:
        ro.chmod(0o755)
    with pytest.raises(RecorderError, match="does not exist"):
        Recorder(tmp_path / "no" / "such" / "dir.mcap").start()
    with pytest.raises(RecorderError, match="is a directory"):
        Recorder(tmp_path).start()
    existing = tmp_path / "old.mcap"
    existing.write_bytes(b"keep me")
    with pytest.raises(RecorderError, match="already exists"):
        Recorder(existing).start()
    assert existing.read_bytes() == b"keep me"
    Recorder(existing, overwrite=True).start().close()
    assert Recording(existing).complete


@pytest.mark.realtime
def test_dev_full_fails_at_start():
    t0 = time.monotonic()
    with pytest.raises(RecorderError, match="No space left on device.*full"):
        Recorder("/dev/full").start()
    assert time.monotonic() - t0 < 1.0


@pytest.mark.realtime
def test_disk_full_during_recording_stops_cleanly(tmp_path, monkeypatch):
    """ENOSPC after some chunks: the error is reported, producers never block, the chunks
    already written stay readable."""
    limit = 200_000
    real_write = recorder_mod._Sink.write

    def write(self, data):
        if self.pos + len(data) > limit:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real_write(self, data)

    monkeypatch.setattr(recorder_mod._Sink, "write", write)
    path = tmp_path / "full.mcap"
    rec = Recorder(path, flush_interval=0.05, compression="none").start()
    block = np.zeros((4410, 1), dtype=np.int16)
    sent = 0
    t0 = time.monotonic()
    while not rec.failed and time.monotonic() - t0 < 10:
        rec.write_audio("index", Chunk(block, sent * 4410, 44100.0, 100.0 + sent * 0.1,
                                       44100.0))
        sent += 1
        time.sleep(0.01)
    assert rec.failed and "No space left on device" in str(rec.error)
    assert not rec.write_event("index", "late")  # refused at once, counted
    t1 = time.monotonic()
    st = rec.close()
    assert time.monotonic() - t1 < 1.0
    assert st.dropped_total >= 2
    assert st.written["/fingertip/index/audio"] + st.dropped["/fingertip/index/audio"] == sent
    r = Recording(path)
    got = [x.msg.first_index for x in r.records(kinds=("audio",))]
    assert r.truncated and len(got) == st.written["/fingertip/index/audio"] >= 1
    assert got == [k * 4410 for k in range(len(got))]
    with pytest.raises(RecorderError):
        with Recorder(tmp_path / "full2.mcap", compression="none") as rec2:
            rec2.write_audio("index", Chunk(np.zeros((200_000, 1), np.int16), 0, 44100.0,
                                            1.0, 44100.0))
            time.sleep(0.3)


@pytest.mark.parametrize("compression", ["none", "lz4", "zstd"])
def test_compressions_and_fsync(tmp_path, compression):
    path = tmp_path / f"{compression}.mcap"
    with Recorder(path, compression=compression, fsync=True) as rec:
        rec.write_event("a", "x", 1.0)
        assert rec.flush()
        rec.write_wrench("a", 5.0, (1.0, 2.0), (0.1, 0.2, 0.3))
    recs = list(Recording(path).records())
    assert [r.kind for r in recs] == ["events", "wrench"]
    assert recs[1].msg.force == (1.0, 2.0, 0.0) and recs[1].msg.torque == (0.1, 0.2, 0.3)


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


def test_audio_a_pump_had_not_read_at_close_is_recorded(tmp_path):
    """close() lets the audio pump record what its source captured before the stop; it
    used to refuse those last chunks as dropped whenever the pump was behind (CPU load)."""
    from fingertip.audio import SimulatedSource

    class SlowReads(SimulatedSource):
        def read(self, *args, **kwargs):
            time.sleep(0.05)  # a consumer the scheduler keeps away: data piles up meanwhile
            return super().read(*args, **kwargs)

    src = SlowReads(lambda t: np.sin(t), 44100, realtime=True)
    rec = Recorder(tmp_path / "audio.mcap").start()
    rec.record_audio(src, "index")
    time.sleep(0.3)
    src.stop()
    st = rec.close()
    assert src.stats.frames > 0.25 * 44100
    assert st.dropped == {}
    assert st.audio_frames["index"] == src.stats.frames
