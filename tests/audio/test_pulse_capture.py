"""Capture through the real stack: paplay -> PulseAudio null sink -> monitor -> ALSA pulse
plugin -> PortAudio -> sounddevice -> SoundDeviceSource. No sound card needed."""
from __future__ import annotations

import time

import numpy as np
import pytest
import soundfile as sf

from fingertip.audio import (
    AudioDeviceNotFound, AudioSettingsError, Chunk, SoundDeviceSource, find_input_device,
    list_input_devices, refresh_devices,
)
from fingertip.audio.live import SLEW, WARMUP_S, WARMUP_SLEW

from .pulse import PulseError, check_tools

FS = 44100
pytestmark = pytest.mark.slow


def test_signal() -> np.ndarray:
    """2.0 s, int16: silence, a 200 Hz - 8 kHz chirp, silence, a click train, silence."""
    def silence(s: float) -> np.ndarray:
        return np.zeros(round(s * FS))
    t = np.arange(FS) / FS
    chirp = 0.5 * np.sin(2 * np.pi * (200 * t + (8000 - 200) * t ** 2 / 2))
    clicks = np.zeros(FS // 2)
    for i, k in enumerate(range(0, len(clicks) - 100, FS // 20)):
        sign = 1 if i % 2 == 0 else -1
        clicks[k:k + 5] = sign * np.array([0.9, -0.9, 0.45, -0.45, 0.15])
    x = np.concatenate([silence(0.2), chirp, silence(0.1), clicks, silence(0.2)])
    return np.round(x * 32767).astype(np.int16)


test_signal.__test__ = False  # a helper, not a test


@pytest.fixture(scope="module")
def wav(pulse_server, tmp_path_factory):
    x = test_signal()
    path = tmp_path_factory.mktemp("pulse-wav") / "chirp_clicks.wav"
    sf.write(path, x, FS, subtype="PCM_16")
    return path, x


def as_int16_values(samples: np.ndarray) -> np.ndarray:
    """Captured samples back to the 16-bit values played, asserting the conversion is exact."""
    if samples.dtype == np.int16:
        return samples.astype(np.int64)
    if samples.dtype == np.int32:
        assert np.all(samples & 0xFFFF == 0), "int32 capture of a 16-bit sink: low bits set"
        return (samples >> 16).astype(np.int64)
    scaled = samples.astype(np.float64) * 32768
    assert np.array_equal(scaled, np.round(scaled)), "float32 capture is not exact"
    return scaled.astype(np.int64)


def find_exact(y: np.ndarray, x: np.ndarray) -> int:
    """Offset of x in y: by the first non-zero sample, confirmed by cross-correlation."""
    nz = np.flatnonzero(y)
    assert len(nz), "nothing but silence was captured"
    offset = int(nz[0] - np.flatnonzero(x)[0])
    n = 1 << int(np.ceil(np.log2(len(y) + len(x))))
    xc = np.fft.irfft(np.fft.rfft(y.astype(np.float64), n) *
                      np.conj(np.fft.rfft(x.astype(np.float64), n)), n)
    assert int(np.argmax(xc[:len(y)])) == offset, "cross-correlation disagrees on alignment"
    return offset


def capture_while_playing(server, path, src: SoundDeviceSource, tail_s: float = 0.3
                          ) -> tuple[list[Chunk], float]:
    """Start ``src``, wait until the stream flows, play ``path``, read until it has ended."""
    chunks: list[Chunk] = []
    with src:
        first = src.read(timeout=5.0)
        assert first is not None, "the pulse stream delivered nothing in 5 s"
        chunks.append(first)
        t_launch = time.monotonic()
        player = server.play(path)
        deadline = t_launch + 20.0
        ended = None
        while ended is None or time.monotonic() < ended + tail_s:
            c = src.read(timeout=0.5)
            if c is not None:
                chunks.append(c)
            if ended is None and player.poll() is not None:
                ended = time.monotonic()
            assert time.monotonic() < deadline, "paplay did not finish in 20 s"
        err = player.stderr.read().decode(errors="replace") if player.stderr else ""
        assert player.returncode == 0, f"paplay failed: {err}"
    chunks.extend(src.chunks(timeout=0))  # what came in before stop()
    return chunks, t_launch


def check_timestamps(chunks: list[Chunk], src: SoundDeviceSource) -> None:
    idx = np.array([c.first_index for c in chunks])
    frames = np.array([c.frames for c in chunks])
    t = np.array([c.host_time for c in chunks])
    assert idx[0] == 0 and np.array_equal(idx[1:], idx[:-1] + frames[:-1]), "gap in indices"
    assert all(c.lost_before == 0 for c in chunks)
    assert np.all(np.diff(t) > 0), "timestamps not monotonic"
    # Consistent with the sample count: chunk to chunk within the clock's slew (0.5 % of the
    # blocks started in between: a chunk may end mid-block, so one ~100-frame block more),
    # end to end within the slew plus 1 ms. (The null sink runs about 240 ppm fast against
    # CLOCK_MONOTONIC with these 2 ms blocks; the fit follows it.)
    # In the stream's first WARMUP_S seconds they may catch up faster (WARMUP_SLEW): a host
    # busy while the stream opened delivers the first blocks late and then in a burst.
    dt_frames = np.diff(idx) / FS
    slew = np.where(idx[1:] <= WARMUP_S * FS, WARMUP_SLEW, SLEW) + 1e-4
    assert np.all(np.abs(np.diff(t) - dt_frames) <= slew * (dt_frames + 200 / FS))
    # Unless the first stamp was that late (then the warm-up slew may have been used), end
    # to end within the steady slew plus 1 ms.
    if abs(src.time_of(int(idx[0])) - t[0]) < 0.02:
        span = (idx[-1] - idx[0]) / FS
        assert abs((t[-1] - t[0]) - span) < 5.1e-3 * span + 1e-3
    # The fit's rate within 500 ppm; a chunk's above it by at most the slew while its
    # stamps catch up (the warm-up slew in the stream's first seconds).
    fit = src.time_of(FS) - src.time_of(0)
    assert abs(fit - 1) < 500e-6, fit
    rates = np.array([c.host_rate for c in chunks])
    top = np.where(idx <= WARMUP_S * FS + 2048, 1 / (1 - WARMUP_SLEW), 1 / (1 - SLEW)) + 500e-6
    assert np.all(rates / FS > 1 - 500e-6) and np.all(rates / FS < top)
    # Chunk times are causal (the fit when the block came); they converge on the final fit.
    # How far apart they start depends on how late the first callbacks were scheduled: a
    # few ms on an idle machine, up to about 20 ms with both cores busy, 0.55 s once in a
    # fresh clone's make test (then the warm-up slew catches up within 2.2 s of audio).
    assert abs(src.time_of(int(idx[-1])) - t[-1]) < 0.02


def test_pulse_device_is_listed_and_picked(pulse_server):
    names = [d.name for d in list_input_devices()]
    assert "pulse" in names, names
    refresh_devices()  # PortAudio enumerates again (what the fixture does if need be)
    assert "pulse" in [d.name for d in list_input_devices()]
    dev = find_input_device("PULS")
    assert dev.name == "pulse" and dev.hostapi == "ALSA" and dev.max_input_channels >= 2
    assert dev.alsa_card is None and dev.usb_path is None


def test_missing_device_and_bad_settings_are_clear(pulse_server):
    with pytest.raises(AudioDeviceNotFound,
                       match=r"no input device matching 'Scarlett 2i2'.*'pulse'"):
        SoundDeviceSource("Scarlett 2i2", FS).start()
    with pytest.raises(AudioSettingsError, match="refuses 1e\\+06 Hz.*accepts.*44100"):
        SoundDeviceSource("pulse", 1_000_000).start()
    with pytest.raises(AudioSettingsError, match="input channel"):
        SoundDeviceSource("pulse", FS, channels=64).start()


@pytest.mark.realtime
@pytest.mark.parametrize("dtype,channels", [("int16", 1), ("int32", 1), ("float32", 1),
                                            ("int16", 2)])
def test_capture_is_bit_exact_and_well_timed(pulse_server, wav, dtype, channels):
    path, x = wav
    src = SoundDeviceSource("pulse", FS, channels, dtype, buffer_seconds=30)
    chunks, t_launch = capture_while_playing(pulse_server, path, src)
    samples = np.concatenate([c.samples for c in chunks])
    assert samples.dtype == np.dtype(dtype) and samples.shape[1] == channels
    for ch in range(channels):
        y = as_int16_values(samples[:, ch])
        offset = find_exact(y, x)
        assert offset >= 0 and offset + len(x) <= len(y), "signal cut off"
        np.testing.assert_array_equal(y[offset:offset + len(x)], x)  # every sample
        assert not np.any(y[offset + len(x):]), "something after the signal"
    st = src.stats
    assert (st.input_overflows, st.xruns, st.overruns_frames, st.callback_errors,
            st.stream_errors, st.clock_steps) == (0, 0, 0, 0, 0, 0), st
    assert st.timestamp_source == "frames"  # auto: the pulse plugin's ADC time is unusable
    assert st.frames == st.frames_read == len(samples)
    check_timestamps(chunks, src)
    # The signal's first sample, 0.2 s into the file, is stamped after paplay was launched
    # (within the null sink's render-ahead) and not long after.
    lead = np.flatnonzero(x)[0]
    t_signal = src.time_of(offset + lead)
    assert -0.05 < t_signal - (t_launch + lead / FS) < 0.5


@pytest.mark.realtime
def test_stalled_callback_loses_nothing(pulse_server, wav):
    """The server buffers while the callback is stuck: no loss, no false clock step."""
    path, x = wav

    class Stalling(SoundDeviceSource):
        calls = 0

        def callback(self, indata, frames, time_info, status):
            Stalling.calls += 1
            if Stalling.calls == 100 + 80:  # about 0.4 s into the played signal
                time.sleep(1.0)
            super().callback(indata, frames, time_info, status)

    src = Stalling("pulse", FS, 1, "int16", buffer_seconds=30)
    chunks, _ = capture_while_playing(pulse_server, path, src)
    y = as_int16_values(np.concatenate([c.samples for c in chunks])[:, 0])
    offset = find_exact(y, x)
    np.testing.assert_array_equal(y[offset:offset + len(x)], x)
    st = src.stats
    assert (st.input_overflows, st.overruns_frames, st.clock_steps) == (0, 0, 0), st
    check_timestamps(chunks, src)


def test_slow_consumer_overrun_is_counted_on_a_live_stream(pulse_server):
    src = SoundDeviceSource("pulse", FS, 1, "int16", buffer_seconds=0.2)
    with src:
        assert src.read(timeout=5.0) is not None
        time.sleep(0.6)  # the ring holds 0.2 s
        assert src.stats.overruns_frames > 0  # visible before the next read
        c = src.read(timeout=1.0)
        assert c is not None and c.lost_before > 0
    rest = list(src.chunks(timeout=0))
    st = src.stats
    assert st.overruns_frames == c.lost_before + sum(r.lost_before for r in rest)
    assert st.frames_read + st.overruns_frames + src.ring.available == st.frames
    assert st.input_overflows == 0  # the loss was ours (ring), not the server's


def test_missing_pulseaudio_fails_naming_the_packages(tmp_path):
    with pytest.raises(PulseError, match="pulseaudio pulseaudio-utils libasound2-plugins"):
        check_tools(path=str(tmp_path))
