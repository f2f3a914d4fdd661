"""The feed's bookkeeping, with a transport that keeps what it is given in a list (a test
sink: the real transports are exercised across processes in the other tests): a failing
force model or transport is counted, never raised into the device's thread."""
from __future__ import annotations

import time

import numpy as np
import pytest

from fingertip.audio import Chunk
from fingertip.device import Frame
from fingertip.network.feed import ENCODERS, Feed
from fingertip.record import schemas as S
from fingertip.record.timebase import TimeBase


class ListSink:
    def __init__(self, fail_kinds=()) -> None:
        self.got: list[tuple[str, str, bytes]] = []
        self.fail_kinds = set(fail_kinds)

    def add_fingertip(self, name: str, info=None) -> None:
        pass

    def publish(self, name: str, kind: str, msg) -> None:
        if kind in self.fail_kinds:
            raise OSError("network down")
        self.got.append((name, kind, ENCODERS[kind](msg)))

    def close(self) -> None:
        pass


def frame(seq: int, counts=(1, 2, 3, 4)) -> Frame:
    t = time.monotonic()
    return Frame(seq, 1000 * seq, t, t + 0.001, counts, 0, 0)


def model(counts):
    if counts[0] < 0:
        raise ValueError("out of range")
    return (counts[0] * 0.5, counts[1] * 0.25)


def test_frames_forces_and_failures_are_counted():
    sink = ListSink()
    tb = TimeBase(0)
    feed = Feed(sink, timebase=tb)
    feed.add_fingertip("index", model)
    feed.frame("index", frame(1))
    feed.frame("index", frame(2, (-1, 0, 0, 0)))  # the model refuses this one
    kinds = [k for _, k, _ in sink.got]
    assert kinds == ["raw", "wrench", "raw"]
    raw = S.decode_raw(sink.got[0][2])
    assert raw.seq == 1 and raw.counts == (1, 2, 3, 4) and raw.frame_id == "index"
    w = S.decode_wrench(sink.got[1][2])
    assert w.force == (0.5, 0.5, 0.0) and w.stamp_ns == raw.stamp_ns
    assert feed.errors["force_model"] == 1
    assert feed.published[S.topic("index", "raw")] == 2


def test_a_failing_transport_is_counted_not_raised():
    feed = Feed(ListSink(fail_kinds={"raw"}), timebase=TimeBase(0))
    feed.add_fingertip("index")
    for i in range(3):
        feed.frame("index", frame(i))
    feed.event("index", "marker", 1.0)
    assert feed.errors["raw"] == 3 and feed.published[S.topic("index", "events")] == 1


def test_audio_of_an_unsupported_dtype_is_counted():
    sink = ListSink()
    feed = Feed(sink, timebase=TimeBase(0))
    feed.add_fingertip("index")
    good = Chunk(np.zeros((4, 1), np.int16), 0, 44100.0, 10.0, 44100.0)
    bad = Chunk(np.zeros((4, 1), np.float64), 4, 44100.0, 10.1, 44100.0)
    feed.audio("index", good)
    feed.audio("index", bad)
    assert [k for _, k, _ in sink.got] == ["audio"] and feed.errors["audio"] == 1
    m = S.decode_audio(sink.got[0][2])
    assert (m.encoding, m.frames, m.data) == ("S16LE", 4, b"\0" * 8)


def published_audio(late_s: float = 0.0) -> list:
    """What the feed publishes of 0.6 s of 10 ms blocks (as a sound card delivers them),
    each handed over ``late_s`` after its last frame was captured; checked gap-free."""
    from fingertip.audio import SimulatedSource

    sink = ListSink()
    feed = Feed(sink, timebase=TimeBase(0))
    feed.add_fingertip("index")
    # The source paces its blocks from start(); its chunks' times count from host_time0.
    src = SimulatedSource(lambda t: 0.1 * np.sin(t), 8000.0, dtype="int16", blocksize=80,
                          duration=0.6, host_time0=time.monotonic() - late_s)
    feed.pump_audio(src, "index", min_seconds=0.02).join(timeout=10)
    feed.close()
    msgs = [S.decode_audio(d) for _, k, d in sink.got if k == "audio"]
    assert sum(m.frames for m in msgs) == 4800
    assert [m.first_index for m in msgs] == list(np.cumsum([0] + [m.frames for m in msgs])[:-1])
    return msgs


@pytest.mark.realtime  # the chunks' length follows the wall clock of a paced source
@pytest.mark.parametrize("late_s", [0.0, 0.006])
def test_audio_is_published_in_chunks_of_at_least_20_ms_without_gaps(late_s):
    msgs = published_audio(late_s)
    # Chunks hold at least 20 ms, also when blocks come late (a busy host, a card that
    # buffers): every block on its own would make 60 messages.
    full = sum(m.frames >= 160 for m in msgs[:-1])
    assert full >= 0.8 * (len(msgs) - 1), [m.frames for m in msgs]
    assert len(msgs) <= 36
