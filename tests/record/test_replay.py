"""Replay: user code cannot tell a recording from the live device."""
from __future__ import annotations

import time

import numpy as np
import pytest

from fingertip import Fingertip, Frame
from fingertip.audio import AudioSource
from fingertip.record import Recorder, RecordingError, Replay
from fingertip.record.replay import RecordedEvent, Wrench


def user_pipeline(dev, n: int) -> tuple[list[Frame], list[Frame]]:
    """Code written against a Fingertip: a callback plus a reading loop."""
    seen: list[Frame] = []
    dev.add_callback(seen.append)
    dev.start()
    got = [f for _, f in zip(range(n), dev.frames(timeout=2.0), strict=False)]
    dev.stop()
    dev.remove_callback(seen.append)
    return got, seen


def test_frames_are_the_live_frames(session):
    live = session.frames
    with Replay(session.path, speed=None, rebase=False) as rp:
        assert rp.name == "index" and rp.status == "connected"
        assert rp.info.channels == 4 and rp.channels == 4
        got, seen = user_pipeline(rp, len(live) + 10)
    assert len(got) == len(live) and seen[:len(got)] == got
    for a, b in zip(got, live, strict=True):
        assert (a.seq, a.device_time_us, a.counts, a.timeout_mask, a.saturation_mask) == \
            (b.seq, b.device_time_us, b.counts, b.timeout_mask, b.saturation_mask)
        assert a.host_time == pytest.approx(b.host_time, abs=2e-9)
        assert a.arrival_time == pytest.approx(b.arrival_time, abs=2e-9)
        assert type(a) is Frame and a.ok == b.ok
    assert rp.status == "closed" and rp.read(timeout=0.1) is None
    assert rp.stats.frames_ok == len(live)


def test_rebase_shifts_host_times_by_one_constant(session):
    live = session.frames
    with Replay(session.path, speed=None) as rp:
        # The replay starts on its thread, between start() and the first frame: bounds with
        # no tolerance (a t0 taken before opening, within 10 ms, failed at load 7).
        t_start = time.monotonic()
        rp.start()
        got = [rp.read(timeout=2.0)]
        t_first = time.monotonic()
        got += [f for _, f in zip(range(len(live) - 1), rp.frames(timeout=2.0), strict=False)]
        rp.stop()
    shifts = [a.host_time - b.host_time for a, b in zip(got, live, strict=True)]
    assert max(shifts) - min(shifts) < 1e-6
    assert rp.shift == pytest.approx(shifts[0], abs=1e-6)
    # The first message (here the marker event, before the frames) is at the replay's start.
    first_event_delay = session.frames[0].host_time - rp.recording.timebase.to_monotonic(
        next(iter(rp.recording.messages(("raw", "wrench", "audio", "events")))).log_time)
    started = got[0].host_time - first_event_delay
    assert t_start - 1e-6 <= started <= t_first + 1e-6, (t_start, started, t_first)


def test_same_code_live_and_replayed(device, tmp_path):
    path = tmp_path / "r.mcap"
    with Recorder(path) as rec, Fingertip(str(device.link)) as ft:
        rec.attach(ft, "index")
        live, _ = user_pipeline(ft, 60)
    with Replay(path, speed=None, rebase=False) as rp:
        replayed, _ = user_pipeline(rp, 60)
    # The recorder saw every frame the device sent while attached, a few more than the
    # loop read before stopping: the replay starts with the same frames.
    assert [(f.seq, f.counts, f.device_time_us) for f in replayed] == \
        [(f.seq, f.counts, f.device_time_us) for f in live]


@pytest.mark.realtime
@pytest.mark.parametrize("speed", [1.0, 4.0])
def test_paced_playback_takes_the_recorded_time(session, speed):
    live = session.frames
    span = live[-1].arrival_time - live[0].arrival_time
    with Replay(session.path, speed=speed) as rp:
        t0 = time.monotonic()
        rp.start()
        got = list(rp.frames(timeout=2.0))
        took = time.monotonic() - t0
    assert len(got) == len(live)
    assert span / speed - 0.05 < took < span / speed + 0.5


@pytest.mark.realtime
def test_frames_arrive_when_due(session):
    arrivals: list[tuple[float, float]] = []
    with Replay(session.path, speed=1.0) as rp:
        rp.add_callback(lambda f: arrivals.append((time.monotonic(), f.arrival_time)))
        rp.start()
        assert rp.wait(10)
    lateness = [now - due for now, due in arrivals]
    assert min(lateness) > -0.002  # never early
    assert np.median(lateness) < 0.01


def test_audio_source_gives_the_live_chunks(session):
    with Replay(session.path, speed=None, rebase=False) as rp:
        src = rp.audio()
        assert isinstance(src, AudioSource)
        assert (src.sample_rate, src.channels, src.dtype) == (44100.0, 1, np.dtype("int16"))
        src.start()
        rp.start()
        chunks = list(src.chunks(max_frames=441))
        assert src.finished and rp.ended
    live = session.chunks
    got = np.concatenate([c.samples for c in chunks])
    want = np.concatenate([c.samples for c in live])
    np.testing.assert_array_equal(got, want)
    assert chunks[0].first_index == live[0].first_index
    by_index = {c.first_index: c for c in live}
    for c in chunks:
        if c.first_index in by_index:
            assert c.host_time == pytest.approx(by_index[c.first_index].host_time, abs=2e-9)
    assert rp.audio_gap_frames == 0


def test_wrench_and_event_callbacks(session):
    wrenches: list[Wrench] = []
    events: list[RecordedEvent] = []
    with Replay(session.path, speed=None, rebase=False) as rp:
        rp.add_wrench_callback(wrenches.append)
        rp.add_event_callback(events.append)
        rp.start()
        assert rp.wait(10)
    frames = session.frames
    assert len(wrenches) == len(frames)
    for w, f in zip(wrenches, frames, strict=True):
        assert w.force == pytest.approx((f.counts[0] * 1e-3, f.counts[1] * 1e-4, 0.0))
        assert w.host_time == pytest.approx(f.host_time, abs=2e-9)
    assert [(e.kind, e.value, e.detail) for e in events] == [("marker", 1.5, "hello")]
    assert frames[0].host_time - 1.0 < events[0].time < frames[0].host_time


def test_slow_reader_loses_nothing_as_fast_as_possible(session):
    with Replay(session.path, speed=None, queue_size=8) as rp:
        rp.start()
        got = []
        for f in rp.frames(timeout=2.0):
            got.append(f)
            if len(got) < 20:
                time.sleep(0.005)
    assert len(got) == len(session.frames) and rp.stats.overruns == 0


def test_callbacks_only_never_block(session):
    n = []
    with Replay(session.path, speed=None, queue_size=4) as rp:
        rp.add_callback(n.append)
        rp.start()
        assert rp.wait(10)
    assert len(n) == len(session.frames) and rp.stats.overruns > 0


@pytest.mark.realtime
def test_close_stops_a_paced_replay_at_once(session):
    rp = Replay(session.path, speed=0.01).open()
    rp.start()
    time.sleep(0.05)
    t0 = time.monotonic()
    rp.close()
    assert time.monotonic() - t0 < 1.0 and rp.status == "closed"


def test_truncated_recording_replays_up_to_its_last_chunk(session, tmp_path):
    data = session.path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[:len(data) * 2 // 3])
    with Replay(cut, speed=None) as rp:
        rp.start()
        got = list(rp.frames(timeout=2.0))
    assert 0 < len(got) < len(session.frames)
    assert [f.seq for f in got] == [f.seq for f in session.frames[:len(got)]]
    assert rp.recording.truncated


def test_choosing_a_fingertip_and_clear_errors(tmp_path):
    path = tmp_path / "hand.mcap"
    with Recorder(path) as rec:
        for name in ("thumb", "index"):
            rec.write_frame(name, Frame(1, 10, 1.0, 1.0, (1,)))
    with pytest.raises(RecordingError, match="several fingertips.*index, thumb"):
        Replay(path)
    with pytest.raises(RecordingError, match="no fingertip named 'ring'"):
        Replay(path, "ring")
    with Replay(path, "thumb", speed=None) as rp:
        rp.start()
        assert [f.counts for f in rp.frames(timeout=1)] == [(1,)]
        with pytest.raises(RecordingError, match="no audio"):
            rp.audio()
    with pytest.raises(RecordingError, match="no such file"):
        Replay(tmp_path / "nope.mcap")
    (tmp_path / "x.mcap").write_bytes(b"not an mcap file")
    with pytest.raises(RecordingError, match="not an MCAP file"):
        Replay(tmp_path / "x.mcap")
    with pytest.raises(ValueError, match="speed"):
        Replay(path, "thumb", speed=0)
    empty = tmp_path / "empty.mcap"
    Recorder(empty).start().close()
    with pytest.raises(RecordingError, match="no fingertip frames"):
        Replay(empty)


def test_audio_gaps_come_back_as_zeros(tmp_path):
    from fingertip.audio import Chunk

    path = tmp_path / "gap.mcap"
    a = np.arange(1, 101, dtype=np.int16).reshape(100, 1)
    with Recorder(path) as rec:
        rec.write_frame("index", Frame(1, 0, 10.0, 10.0, (0,)))
        rec.write_audio("index", Chunk(a, 1000, 100.0, 10.0, 100.0))
        rec.write_audio("index", Chunk(a, 1150, 100.0, 11.5, 100.0, lost_before=50))
    with Replay(path, speed=None, rebase=False) as rp:
        src = rp.audio()
        src.start()
        rp.start()
        rp.wait(5)
        chunks = list(src.chunks())
    got = np.concatenate([c.samples for c in chunks])[:, 0]
    assert chunks[0].first_index == 1000 and len(got) == 250
    np.testing.assert_array_equal(got[:100], a[:, 0])
    assert not got[100:150].any()
    np.testing.assert_array_equal(got[150:], a[:, 0])
    assert rp.audio_gap_frames == 50
    assert src.time_of(1150) == pytest.approx(11.5)


def test_events_of_the_events_layer_round_trip(tmp_path):
    from fingertip.events import Event

    path = tmp_path / "ev.mcap"
    with Recorder(path) as rec:
        assert rec.write_events("index", [Event(10.0, "contact", 0.4),
                                          Event(10.5, "release")]) == 2
    got: list[RecordedEvent] = []
    with Replay(path, "index", speed=None, rebase=False) as rp:
        rp.add_event_callback(got.append)
        rp.start()
        assert rp.wait(5)
    assert [(e.time, e.kind, e.value) for e in got] == [(10.0, "contact", 0.4),
                                                         (10.5, "release", 0.0)]
