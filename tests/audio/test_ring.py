"""Ring buffer: absolute indices, wraparound, overrun accounting, dtypes, no torn reads."""
from __future__ import annotations

import threading
import tracemalloc

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fingertip.audio import RingBuffer

FS = 44100.0


def ramp(start: int, n: int, channels: int = 1, dtype=np.int32) -> np.ndarray:
    """Frames whose value is their own absolute index (channel c adds c * 1e6)."""
    idx = np.arange(start, start + n, dtype=np.int64)[:, None]
    return (idx % 1_000_000 + np.arange(channels)[None, :] * 1_000_000).astype(dtype)


@pytest.mark.parametrize("dtype", [np.int16, np.int32, np.float32])
@pytest.mark.parametrize("channels", [1, 2])
def test_write_read_keeps_dtype_layout_and_indices(dtype, channels):
    ring = RingBuffer(64, channels, dtype, FS)
    data = (np.arange(40 * channels).reshape(40, channels) - 20).astype(dtype)
    assert ring.write(data[:25], 10.0) == 0
    assert ring.write(data[25:], 10.0 + 25 / FS) == 25
    chunk = ring.read()
    assert chunk.samples.dtype == np.dtype(dtype)
    assert chunk.samples.shape == (40, channels)
    np.testing.assert_array_equal(chunk.samples, data)
    assert (chunk.first_index, chunk.end_index, chunk.lost_before) == (0, 40, 0)
    assert chunk.host_time == 10.0 and chunk.sample_rate == FS
    assert ring.read() is None


def test_buffer_wraparound_in_odd_sizes():
    ring = RingBuffer(10, 2, np.int32, FS)
    written = 0
    got = []
    for _ in range(30):
        ring.write(ramp(written, 7, 2), written / FS)
        written += 7
        while (c := ring.read(max_frames=3)) is not None:
            assert c.lost_before == 0
            got.append(c)
    frames = np.concatenate([c.samples for c in got])
    np.testing.assert_array_equal(frames, ramp(0, written, 2))
    assert [c.first_index for c in got] == list(np.cumsum([0] + [c.frames for c in got[:-1]]))
    assert ring.overruns_frames == 0


def test_frame_counter_runs_past_32_bits():
    start = (1 << 32) - 5
    ring = RingBuffer(8, 1, np.int32, FS, start_index=start)
    ring.write(ramp(start, 6), 1.0)
    ring.write(ramp(start + 6, 6), 1.0 + 6 / FS)
    c = ring.read(max_frames=4)
    assert c.lost_before == 4 and c.first_index == start + 4  # 12 written into 8 frames
    assert c.end_index == start + 8 > (1 << 32)
    np.testing.assert_array_equal(c.samples, ramp(start + 4, 4))
    assert c.host_time == pytest.approx(1.0 + 4 / FS)
    c = ring.read()
    assert (c.first_index, c.end_index) == (start + 8, start + 12)
    assert ring.read_index == start + 12


def test_overrun_is_counted_never_silent():
    ring = RingBuffer(100, 1, np.int16, FS)
    for k in range(0, 250, 50):
        ring.write(ramp(k, 50, dtype=np.int16), k / FS)
    # Before the consumer even looks, the loss shows.
    assert ring.lost_pending == 150
    c = ring.read()
    assert c.lost_before == 150 and c.first_index == 150 and c.frames == 100
    np.testing.assert_array_equal(c.samples, ramp(150, 100, dtype=np.int16))
    assert (ring.overruns_frames, ring.overruns, ring.lost_pending) == (150, 1, 0)
    assert ring.frames_read == 100


def test_block_longer_than_buffer_keeps_its_tail():
    ring = RingBuffer(16, 1, np.int32, FS)
    ring.write(ramp(0, 50), 2.0)
    c = ring.read()
    assert (c.first_index, c.frames, c.lost_before) == (34, 16, 34)
    np.testing.assert_array_equal(c.samples, ramp(34, 16))
    assert c.host_time == pytest.approx(2.0 + 34 / FS)


def test_read_range_by_absolute_index():
    ring = RingBuffer(32, 1, np.int32, FS)
    for k in range(0, 60, 10):
        ring.write(ramp(k, 10), 5.0 + k / FS)
    c = ring.read_range(35, 50)
    np.testing.assert_array_equal(c.samples, ramp(35, 15))
    assert c.host_time == pytest.approx(5.0 + 35 / FS)
    assert ring.read_index == 0  # the cursor does not move
    with pytest.raises(IndexError, match="not captured yet"):
        ring.read_range(50, 61)
    with pytest.raises(IndexError, match="already overwritten"):
        ring.read_range(27, 30)
    with pytest.raises(IndexError, match="longer than the buffer"):
        ring.read_range(0, 33)


def test_out_buffer_is_reused():
    ring = RingBuffer(32, 2, np.float32, FS)
    out = np.zeros((8, 2), np.float32)
    ring.write(np.ones((20, 2), np.float32), 0.0)
    c = ring.read(out=out)
    assert c.frames == 8 and np.shares_memory(c.samples, out)
    with pytest.raises(ValueError):
        ring.read(out=np.zeros((8, 2), np.int16))


def test_float32_is_exact_for_16_and_24_bit_values():
    """float32 holds every 16-bit and 24-bit sample value exactly (PortAudio's conversion)."""
    i16 = np.arange(-32768, 32768, dtype=np.int32)
    f = (i16 / 32768.0).astype(np.float32)
    ring = RingBuffer(len(f), 1, np.float32, FS)
    ring.write(f, 0.0)
    back = ring.read().samples[:, 0].astype(np.float64) * 32768
    np.testing.assert_array_equal(back, i16)
    i24 = np.random.default_rng(1).integers(-(1 << 23), 1 << 23, 100_000)
    f24 = (i24 / float(1 << 23)).astype(np.float32)
    np.testing.assert_array_equal(f24.astype(np.float64) * (1 << 23), i24)
    # 24-bit cards in int32: left-aligned, the low byte zero, kept exactly.
    ring32 = RingBuffer(len(i24), 1, np.int32, FS)
    ring32.write((i24 << 8).astype(np.int32), 0.0)
    got = ring32.read().samples[:, 0]
    assert np.all(got & 0xFF == 0)
    np.testing.assert_array_equal(got >> 8, i24)


def test_float_into_integer_ring_is_refused():
    ring = RingBuffer(8, 1, np.int16, FS)
    with pytest.raises(TypeError):
        ring.write(np.zeros(4, np.float64), 0.0)
    with pytest.raises(ValueError, match="2-channel"):
        RingBuffer(8, 2, np.int16, FS).write(np.zeros(4, np.int16), 0.0)
    with pytest.raises(ValueError, match="unsupported"):
        RingBuffer(8, 1, np.float64, FS)


def test_time_of_uses_block_records_and_survives_recycling():
    ring = RingBuffer(1000, 1, np.int16, FS, max_blocks=4)
    drift_rate = FS * (1 + 50e-6)
    for b in range(10):
        ring.write(np.zeros(10, np.int16), 100.0 + b * 10 / drift_rate, drift_rate)
    assert ring.time_of(95) == pytest.approx(100.0 + 95 / drift_rate, abs=1e-12)
    # Blocks 0..5 lost their records: extrapolated from the oldest record held.
    assert ring.time_of(3) == pytest.approx(100.0 + 3 / drift_rate, abs=1e-9)
    c = ring.read_range(57, 63)
    assert c.host_rate == drift_rate
    np.testing.assert_allclose(c.times(), 100.0 + np.arange(57, 63) / drift_rate, atol=1e-9)


def test_write_does_not_allocate():
    """The audio callback's path: no sample-sized allocation per block."""
    ring = RingBuffer(4096, 2, np.float32, FS)
    block = np.ones((441, 2), np.float32)
    for i in range(20):
        ring.write(block, i * 0.01)
    tracemalloc.start()
    try:
        before = tracemalloc.take_snapshot()
        for i in range(2000):
            ring.write(block, i * 0.01)
        after = tracemalloc.take_snapshot()
    finally:
        tracemalloc.stop()
    grown = sum(s.size_diff for s in after.compare_to(before, "filename") if s.size_diff > 0)
    assert grown < 4096, grown  # 2000 blocks of 3.5 kB each would be 7 MB


@given(st.lists(st.tuples(st.integers(0, 40), st.integers(0, 3)), max_size=60),
       st.integers(1, 50), st.sampled_from([0, (1 << 31) - 7, (1 << 40)]))
def test_model_every_frame_read_once_or_counted_lost(ops, capacity, start):
    ring = RingBuffer(capacity, 1, np.int32, FS, start_index=start)
    written = start
    expect_next = start
    lost = 0
    for n_write, n_reads in ops:
        ring.write(ramp(written, n_write), written / FS)
        written += n_write
        for _ in range(n_reads):
            c = ring.read(max_frames=17)
            if c is None:
                assert ring.available == 0
                continue
            lost += c.lost_before
            assert c.first_index == expect_next + c.lost_before
            assert c.first_index >= written - capacity
            np.testing.assert_array_equal(c.samples, ramp(c.first_index, c.frames))
            assert c.host_time == pytest.approx(c.first_index / FS)
            expect_next = c.end_index
    assert ring.overruns_frames == lost
    # `available` still includes frames already overwritten (they show in lost_pending).
    assert ring.frames_read + lost + ring.available == written - start
    assert ring.lost_pending == max(0, ring.available - capacity)


def test_concurrent_producer_and_consumer_never_see_torn_frames():
    ring = RingBuffer(512, 1, np.int32, FS)
    total = 400_000
    done = threading.Event()

    def produce():
        k = 0
        while k < total:
            n = min(97, total - k)
            ring.write(ramp(k, n), k / FS)
            k += n
        done.set()

    t = threading.Thread(target=produce)
    t.start()
    seen = lost = 0
    nxt = 0
    while True:
        c = ring.read()
        if c is None:
            if done.is_set() and ring.available == 0:
                break
            continue
        assert c.first_index == nxt + c.lost_before
        np.testing.assert_array_equal(c.samples, ramp(c.first_index, c.frames))
        seen += c.frames
        lost += c.lost_before
        nxt = c.end_index
    t.join()
    assert seen + lost == total
    assert ring.overruns_frames == lost
