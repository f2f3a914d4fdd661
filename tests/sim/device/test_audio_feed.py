"""Virtual audio through the real capture path: a simulated slide played into the private
PulseAudio null sink (tests/audio/pulse.py), captured by SoundDeviceSource(device='pulse').

At the sink's rate the samples come back bit-exact (16-bit); played at 48 kHz into the
44.1 kHz sink, PulseAudio resamples them and they are compared by cross-correlation.
"""
from __future__ import annotations

import os
import time

import numpy as np
import pytest

from fingertip.audio import SoundDeviceSource
from fingertip.sim.device.audio_feed import AudioFeed, AudioFeedError, on_16bit_grid, play
from fingertip.sim.dataset import resample
from fingertip.sim.physics import Idle, Slide, simulate
from tests.audio.conftest import pulse_server  # noqa: F401  (the private PulseAudio server)

FS = 44100
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def slide():
    trace = simulate(Slide("coarse_fabric", speed_mm_s=25, normal_n=1.2, duration=1.0,
                           seed=4), seed=4).audio
    assert trace is not None and trace.fs == FS
    return trace


def capture_feed(feed: AudioFeed, dtype: str = "int16", tail_s: float = 0.3) -> np.ndarray:
    """Start capturing, wait until the stream flows, play ``feed``, read until it is done."""
    chunks = []
    with SoundDeviceSource("pulse", FS, 1, dtype, buffer_seconds=30) as src:
        first = src.read(timeout=5.0)
        assert first is not None, "the pulse stream delivered nothing in 5 s"
        chunks.append(first)
        with feed:
            deadline = time.monotonic() + feed.duration_s + 20.0
            ended = None
            while ended is None or time.monotonic() < ended + tail_s:
                c = src.read(timeout=0.5)
                if c is not None:
                    chunks.append(c)
                if ended is None and not feed.running:
                    ended = time.monotonic()
                assert time.monotonic() < deadline, f"{feed.player} did not finish"
            assert feed.wait(5.0)
        chunks.extend(src.chunks(timeout=0))
        assert src.stats.input_overflows == 0
    idx = [c.first_index for c in chunks]
    assert idx == sorted(idx) and all(c.lost_before == 0 for c in chunks)
    return np.concatenate([c.samples[:, 0] for c in chunks])


def xcorr(y: np.ndarray, x: np.ndarray) -> np.ndarray:
    n = 1 << int(np.ceil(np.log2(len(y) + len(x))))
    return np.fft.irfft(np.fft.rfft(y, n) * np.conj(np.fft.rfft(x, n)), n)[:len(y)]


@pytest.mark.parametrize("player", ["paplay", "pacat"])
def test_slide_is_captured_bit_exact(pulse_server, slide, player):  # noqa: F811
    feed = AudioFeed(slide, sink=pulse_server.sink, player=player)
    assert feed.exact16 and feed.fs == FS
    assert feed.frames == len(slide.samples) + feed.lead_in_frames
    y = capture_feed(feed).astype(np.int64)
    x = np.rint(slide.samples.astype(np.float64) * 32768).astype(np.int64)
    offset = int(np.argmax(xcorr(y.astype(float), x.astype(float))))
    assert offset + len(x) <= len(y), "the capture ends before the trace does"
    np.testing.assert_array_equal(y[offset:offset + len(x)], x)  # every sample, 16 bits
    assert feed.pid is not None and not feed.running
    with pytest.raises(ProcessLookupError):
        os.kill(feed.pid, 0)  # reaped: nothing left behind


def test_resampled_trace_matches_by_cross_correlation(pulse_server, slide):  # noqa: F811
    x48 = resample(slide.samples, FS, 48000)
    feed = AudioFeed(x48, 48000, sink=pulse_server.sink)
    assert not feed.exact16  # float32 WAV: PulseAudio converts and resamples to 44.1 kHz
    y = capture_feed(feed, "float32").astype(np.float64)
    x = slide.samples.astype(np.float64)
    c = xcorr(y, x)
    k = int(np.argmax(c))
    seg = y[k:k + len(x)]
    assert len(seg) == len(x)
    peak = float(np.dot(seg, x) / np.sqrt(np.dot(seg, seg) * np.dot(x, x)))
    assert peak > 0.99, f"cross-correlation peak {peak:.7f}"  # seen: 0.9999976


@pytest.mark.realtime
def test_stop_kills_the_player_by_pid(pulse_server):  # noqa: F811
    trace = simulate(Idle(duration=5.0, signals=("vibration",)), seed=1).audio
    feed = AudioFeed(trace, sink=pulse_server.sink).start()
    time.sleep(0.3)
    assert feed.running
    pid, wav = feed.pid, feed.trace_file
    assert wav is not None and wav.exists()
    t0 = time.monotonic()
    feed.stop()
    assert time.monotonic() - t0 < 2.0
    assert not feed.running and feed.returncode is not None
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)
    assert feed.trace_file is None and not wav.exists()  # the temporary WAV is gone
    assert not wav.parent.exists()
    feed.stop()  # twice is fine


def test_unknown_sink_is_a_clear_error(pulse_server, slide):  # noqa: F811
    feed = AudioFeed(slide, sink="no_such_sink").start()
    try:
        with pytest.raises(AudioFeedError, match="paplay exited with .*no_such_sink"):
            feed.wait(10.0)
    finally:
        feed.stop()
    with pytest.raises(AudioFeedError):
        play(slide, sink="no_such_sink", player="pacat")


def test_missing_player_names_the_package(slide):
    feed = AudioFeed(slide, env={"PATH": "/nonexistent"})
    with pytest.raises(AudioFeedError, match="pulseaudio-utils"):
        feed.start()
    assert feed.proc is None and feed.trace_file is None


def test_arguments_are_checked():
    assert on_16bit_grid(np.array([0.5, -1.0, 32767 / 32768], np.float32))
    assert not on_16bit_grid(np.array([1.0]))            # +1.0 is beyond int16
    assert not on_16bit_grid(np.array([0.1]))
    assert on_16bit_grid(np.array([3, -4], np.int16))
    with pytest.raises(ValueError, match="fs"):
        AudioFeed(np.zeros(10))
    with pytest.raises(ValueError, match="player"):
        AudioFeed(np.zeros(10), 44100, player="aplay")
    with pytest.raises(ValueError, match="NaN"):
        AudioFeed(np.array([0.0, np.nan]), 44100)
    with pytest.raises(ValueError, match="n > 0"):
        AudioFeed(np.zeros(0), 44100)
