"""The recorder's queue and writer thread: nothing lost between threads, a full queue or a
full disk counted and reported, never a hang."""
from __future__ import annotations

import errno
import os
import threading
import time
from collections import Counter

import numpy as np
import pytest

from fingertip.audio import Chunk
from fingertip.record import Recorder, RecorderError, Recording
from fingertip.record.sink import Sink
import fingertip.record.writer as writer_module


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
    real_encode = writer_module.encode_item

    def slow_encode(*args, **kwargs):  # a writer thread stuck behind a slow disk
        gate.wait(5)
        return real_encode(*args, **kwargs)

    monkeypatch.setattr(writer_module, "encode_item", slow_encode)
    rec = Recorder(tmp_path / "q.mcap", queue_size=10).start()
    results = Counter(rec.write_event("a", "x", float(i)) for i in range(100))
    gate.set()
    st = rec.close()
    assert results[True] + results[False] == 100 and results[False] >= 80
    assert st.dropped["/fingertip/a/events"] == results[False]
    assert st.written["/fingertip/a/events"] == results[True]
    assert st.queue_high_water >= 9


@pytest.mark.realtime
def test_disk_full_during_recording_stops_cleanly(tmp_path, monkeypatch):
    """ENOSPC after some chunks: the error is reported, producers never block, the chunks
    already written stay readable."""
    limit = 200_000
    real_write = Sink.write

    def write(self, data):
        if self.pos + len(data) > limit:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real_write(self, data)

    monkeypatch.setattr(Sink, "write", write)
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
