"""SimulatedSource: a function of time behind the same interface as a sound card."""
from __future__ import annotations

import time

import numpy as np
import pytest

from fingertip.audio import AudioSource, SimulatedSource

FS = 44100


def sine(f: float = 1000.0, amp: float = 0.5):
    return lambda t: amp * np.sin(2 * np.pi * f * t)


def test_free_running_is_sample_exact_and_lossless():
    src = SimulatedSource(sine(), FS, realtime=False, duration=1.0, host_time0=7.0)
    assert isinstance(src, AudioSource)
    with src:
        chunks = list(src.chunks())
    y = np.concatenate([c.samples for c in chunks])[:, 0]
    assert y.dtype == np.float32 and len(y) == FS
    k = np.arange(FS)
    np.testing.assert_allclose(y, 0.5 * np.sin(2 * np.pi * 1000 * k / FS), atol=1e-7)
    for c in chunks:
        assert c.host_time == 7.0 + c.first_index / FS
    assert src.time_of(FS) == 8.0
    st = src.stats
    assert (st.frames, st.frames_read, st.overruns_frames) == (FS, FS, 0)


def test_integer_output_is_rounded_and_clipped_like_a_card():
    levels = np.array([0.0, 0.5, -0.5, 1.0, -1.0, 2.0, -2.0, 1 / 32768, 0.4 / 32768])
    src = SimulatedSource(lambda t: levels[:len(t)], FS, dtype="int16", blocksize=len(levels),
                          realtime=False, duration=len(levels) / FS)
    with src:
        got = src.read().samples[:, 0]
    np.testing.assert_array_equal(got, [0, 16384, -16384, 32767, -32768, 32767, -32768, 1, 0])
    src32 = SimulatedSource(lambda t: np.full(len(t), -1.0), FS, dtype="int32",
                            realtime=False, duration=0.01)
    with src32:
        assert src32.read().samples[0, 0] == -(1 << 31)


def test_integer_samples_pass_through_unchanged():
    src = SimulatedSource(lambda t: np.round(t * FS).astype(np.int64) % 30000, FS,
                          dtype="int16", realtime=False, duration=0.1)
    with src:
        got = np.concatenate([c.samples for c in src.chunks()])[:, 0]
    np.testing.assert_array_equal(got, np.arange(len(got)) % 30000)


def test_stereo_from_one_channel_and_from_two():
    mono = SimulatedSource(sine(), FS, channels=2, realtime=False, duration=0.05)
    with mono:
        s = np.concatenate([c.samples for c in mono.chunks()])
    np.testing.assert_array_equal(s[:, 0], s[:, 1])
    two = SimulatedSource(lambda t: np.stack([np.sin(t), np.cos(t)], axis=1), FS, channels=2,
                          realtime=False, duration=0.05)
    with two:
        s = np.concatenate([c.samples for c in two.chunks()])
    t = np.arange(len(s)) / FS
    np.testing.assert_allclose(s, np.stack([np.sin(t), np.cos(t)], axis=1), atol=1e-7)


@pytest.mark.realtime
def test_realtime_is_paced_and_stamped_ideally():
    src = SimulatedSource(sine(440), FS, blocksize=441, realtime=True, duration=0.3)
    t_start = time.monotonic()
    with src:
        chunks = []
        for c in src.chunks(timeout=2.0):
            assert time.monotonic() >= c.time_of(c.end_index - 1) - 1e-3
            chunks.append(c)
    elapsed = time.monotonic() - t_start
    assert 0.29 <= elapsed < 1.0, elapsed
    assert sum(c.frames for c in chunks) == round(0.3 * FS)
    # Produced in 441-frame blocks; a reader the scheduler kept away for a while takes the
    # blocks that came meanwhile in one chunk, as from a sound card (seen at load 5).
    assert all(c.frames % 441 == 0 for c in chunks)
    assert src.stats.late_blocks < 3  # a loaded CI machine may be late once or twice


def test_runs_until_stopped_without_duration():
    src = SimulatedSource(sine(), FS, realtime=True)
    with src:
        first = src.read(timeout=1.0)
        assert first is not None and src.running
        time.sleep(0.05)
    assert src.finished and not src.running
    rest = list(src.chunks(timeout=0))  # what was captured before stop stays readable
    assert sum(c.frames for c in rest) + first.frames == src.stats.frames


def test_a_broken_function_is_reported():
    bad = SimulatedSource(lambda t: np.zeros(3), FS, realtime=False, duration=0.1)
    with bad, pytest.raises(ValueError, match="returned shape"):
        bad.read()
    paced = SimulatedSource(lambda t: np.zeros(3), FS, realtime=True, duration=0.1)
    with paced:
        assert paced.read(timeout=1.0) is None
    assert paced.stats.callback_errors == 1 and paced.finished


@pytest.mark.realtime
def test_read_timeout_returns_none_while_running():
    src = SimulatedSource(sine(), FS, blocksize=FS // 2, realtime=True)
    with src:
        t0 = time.monotonic()
        assert src.read(timeout=0.05) is None
        assert time.monotonic() - t0 < 0.4
        assert src.read(timeout=0) is None
        assert src.read(timeout=2.0) is not None
