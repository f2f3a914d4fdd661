"""SoundDeviceSource's callback, driven by hand: timestamps, status flags, errors.

No PortAudio here: the callback gets what PortAudio would pass (indata, frame count, time
info, status flags) and a host clock the test controls. The real stack: test_pulse_capture.
"""
from __future__ import annotations

import logging
import random
from dataclasses import dataclass

import numpy as np
import pytest

from fingertip.audio import InputDevice, SoundDeviceSource
from fingertip.audio.live import SLEW, WARMUP_S, WARMUP_SLEW

FS = 44100.0
USB_CARD = InputDevice(2, "USB Audio Device: - (hw:1,0)", "ALSA", 1, FS, 1, "1-2.3")
PULSE = InputDevice(0, "pulse", "ALSA", 32, FS)
STREAM_CLOCK = 1.7e9  # PortAudio's ALSA stream clock reads like the epoch


@dataclass
class TimeInfo:
    inputBufferAdcTime: float
    currentTime: float
    outputBufferDacTime: float = 0.0


@dataclass
class Status:
    input_overflow: bool = False
    input_underflow: bool = False

    def __bool__(self) -> bool:
        return self.input_overflow or self.input_underflow


def prepared(device: InputDevice, timestamps: str = "auto", latency: float = 0.005,
             channels: int = 1) -> SoundDeviceSource:
    src = SoundDeviceSource(device.index, FS, channels, "int16", timestamps=timestamps)
    src.start_external(device)
    src.latency = latency
    return src


def drive(src: SoundDeviceSource, seconds: float, *, skew_ppm: float = 0.0, block: int = 441,
          latency: float = 0.005, adc=lambda i, t: t, seed: int = 1, status=lambda i: None,
          t0: float = 1000.0, stall_s: float = 0.0):
    """Run callbacks for ``seconds`` of audio from a card ``skew_ppm`` slow.

    Returns (block first index, true host time of that frame) pairs. ``adc(i, true_adc)``
    lets a test corrupt the ADC time of callback i. ``stall_s``: the host stalls as the
    stream opens; the blocks due before then come in a burst when it ends.
    """
    rng = random.Random(seed)
    skew = skew_ppm * 1e-6
    truth = []
    k = 0
    i = 0
    while k < seconds * FS:
        t_first = t0 + k / FS * (1 + skew)
        t_end = t0 + (k + block) / FS * (1 + skew)
        now = t_end + latency + rng.expovariate(1 / 0.0015)
        now = max(now, t0 + stall_s + i * 20e-6)
        src.clock = lambda now=now: now
        data = (np.arange(k, k + block) % 30000).astype(np.int16).reshape(-1, 1)
        data = np.repeat(data, src.channels, axis=1)
        cur = now - rng.uniform(0, 0.0003) + STREAM_CLOCK
        src.callback(data, block, TimeInfo(adc(i, t_first + STREAM_CLOCK), cur),
                      status(i) or Status())
        truth.append((k, t_first))
        k += block
        i += 1
    return truth


def read_all(src: SoundDeviceSource, max_frames: int | None = None):
    chunks = []
    while (c := src.ring.read(max_frames)) is not None:
        chunks.append(c)
    return chunks


@pytest.mark.parametrize("skew_ppm", [-100.0, 100.0])
def test_adc_times_of_a_hardware_card_are_used(skew_ppm):
    src = prepared(USB_CARD)
    truth = drive(src, 30.0, skew_ppm=skew_ppm)
    st = src.stats
    assert st.timestamp_source == "adc" and st.adc_time_rejected == 0
    assert st.frames == truth[-1][0] + 441 and st.blocks == len(truth)
    errs = [src.time_of(k) - t for k, t in truth[-200:]]
    assert max(abs(e) for e in errs) < 0.2e-3
    chunk_errs = [src.ring.time_of(k) - t for k, t in truth[len(truth) // 2:]]
    assert max(abs(e) for e in chunk_errs) < 0.5e-3


@pytest.mark.parametrize("device", [USB_CARD, PULSE], ids=["adc-zero", "pulse"])
def test_frame_counts_when_adc_time_is_zero_or_untrusted(device):
    src = prepared(device, latency=0.005)
    truth = drive(src, 30.0, skew_ppm=80.0, latency=0.005, adc=lambda i, t: 0.0)
    st = src.stats
    assert st.timestamp_source == "frames"
    # The card reports 0: rejected (counted); pulse: never even looked at.
    assert st.adc_time_rejected == (3 if device is USB_CARD else 0)
    errs = [src.time_of(k) - t for k, t in truth[-200:]]
    assert max(abs(e) for e in errs) < 0.5e-3  # true latency == reported latency here
    chunks = read_all(src)
    times = np.array([c.host_time for c in chunks])
    idx = np.array([c.first_index for c in chunks])
    assert np.all(np.diff(times) > 0)
    # Consistent with the sample count: at most the slew (0.5 %) off nominal per block.
    np.testing.assert_allclose(np.diff(times), np.diff(idx) / FS, rtol=5.1e-3)


def test_a_stall_as_the_stream_opens_leaves_the_stamps_within_the_warm_up():
    """The first callbacks come 0.6 s late, then in a burst: the first stamps are late by
    the stall (nothing causal can know better), and the stamps catch up with the fit within
    the warm-up instead of at the steady slew (0.5 %: two minutes for 0.6 s)."""
    src = prepared(PULSE, latency=0.005)
    truth = drive(src, 10.0, latency=0.005, stall_s=0.6)
    assert src.stats.clock_steps == 0 and src.stats.timestamp_source == "frames"
    chunks = read_all(src, 441)  # one chunk per block
    idx = np.array([c.first_index for c in chunks])
    times = np.array([c.host_time for c in chunks])
    assert np.all(np.diff(times) > 0)
    true = dict(truth)
    err = np.array([times[i] - true[k] for i, k in enumerate(idx)])
    assert err[0] > 0.5  # stamped when it came
    warm = idx[1:] <= WARMUP_S * FS
    ratio = np.diff(times) / (np.diff(idx) / FS)
    assert ratio[warm].min() >= 1 - WARMUP_SLEW - 1e-9
    assert np.all(np.abs(ratio[~warm] - 1) <= 5.1e-3)
    late = idx > 3.0 * FS  # 0.6 s caught up at 25 %: after 2.4 s of audio
    assert np.all(np.abs(err[late]) < 1e-3), err[late].max()
    assert abs(src.time_of(int(idx[-1])) - times[-1]) < 1e-3


@pytest.mark.parametrize("stall_s", [0.0, 0.6])
def test_chunk_times_never_go_back_whichever_frame_a_chunk_starts_at(stall_s):
    """Read in chunks that do not line up with the blocks (a reader takes what has come):
    while the stamps catch up (a stall as the stream opened, or a refit that moved the line
    back), a chunk that starts late in one block is still stamped before the next block's
    first frame. (A busy run of the pulse capture test once saw one go back.)"""
    src = prepared(PULSE, latency=0.005)
    drive(src, 10.0, latency=0.005, stall_s=stall_s)
    chunks = read_all(src, 100)
    times = np.array([c.host_time for c in chunks])
    idx = np.array([c.first_index for c in chunks])
    assert np.all(np.diff(times) > 0), np.flatnonzero(np.diff(times) <= 0)[:5]
    # Catching up, frames come closer together by at most the slew (a fit that moves
    # forward is followed at once).
    ratio = np.diff(times) / (np.diff(idx) / FS)
    warm = idx[1:] <= WARMUP_S * FS
    assert ratio[warm].min() >= 1 - WARMUP_SLEW - 1e-9
    assert ratio[~warm].min() >= 1 - SLEW - 1e-9


def test_adc_time_that_jumps_switches_to_frames_and_counts_the_step():
    # Like the ALSA pulse plugin when playback starts: the reported latency shrinks by
    # half a second over a few hundred callbacks.
    def jumping(i, t):
        return t - 0.2 + (0.0018 * (i - 500) if i > 500 else 0.0)
    src = prepared(USB_CARD)
    truth = drive(src, 20.0, adc=jumping)
    st = src.stats
    assert st.timestamp_source == "frames"
    assert st.adc_time_rejected >= 1 and st.clock_steps >= 1
    chunks = read_all(src)
    assert np.all(np.diff([c.host_time for c in chunks]) > 0)
    errs = [src.time_of(k) - t for k, t in truth[-100:]]
    assert max(abs(e) for e in errs) < 0.5e-3


def test_forced_frames_mode_ignores_adc():
    src = prepared(USB_CARD, timestamps="frames")
    drive(src, 2.0, adc=lambda i, t: t - 5.0)
    assert src.stats.timestamp_source == "frames" and src.stats.adc_time_rejected == 0


def test_overflow_flags_are_counted_and_logged(caplog):
    src = prepared(PULSE, channels=2)
    flags = {10: Status(input_overflow=True), 11: Status(input_overflow=True),
             40: Status(input_underflow=True)}
    drive(src, 1.0, status=flags.get)
    st = src.stats
    assert (st.input_overflows, st.input_underflows, st.xruns) == (2, 1, 3)
    with caplog.at_level(logging.WARNING, logger="fingertip.audio"):
        chunk = src.read(timeout=0)
    assert "2 input overflow(s)" in caplog.text
    assert chunk.samples.shape == (100 * 441, 2)


def test_errors_in_the_callback_are_counted_not_raised(caplog):
    src = prepared(PULSE)
    src.callback(np.zeros((10, 3), np.int16), 10, TimeInfo(0.0, 0.0), Status())
    src.callback(np.zeros((10, 3), np.int16), 10, TimeInfo(0.0, 0.0), Status())
    assert src.stats.callback_errors == 2 and src.stats.frames == 0
    with caplog.at_level(logging.ERROR, logger="fingertip.audio"):
        src.read(timeout=0)
    assert "audio callback failed" in caplog.text and "channel" in caplog.text


def test_ring_overrun_in_a_live_stream_is_visible_in_stats():
    src = SoundDeviceSource(USB_CARD.index, FS, 1, "int16", buffer_seconds=0.5)
    src.start_external(USB_CARD)
    drive(src, 2.0)
    st = src.stats
    assert st.overruns_frames == src.ring.write_index - src.ring.capacity
    c = src.read(timeout=0)
    assert c.lost_before == st.overruns_frames


def test_settings_are_checked_before_any_device_is_touched():
    with pytest.raises(ValueError, match="timestamps"):
        SoundDeviceSource(timestamps="wall")
    with pytest.raises(ValueError, match="int16, int32"):
        SoundDeviceSource(dtype="int8")
    with pytest.raises(ValueError, match="channel"):
        SoundDeviceSource(channels=0)
