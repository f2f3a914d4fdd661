"""Live capture from a sound card (or a sound server) through sounddevice / PortAudio.

The PortAudio callback copies each block into the ring buffer (no allocation), counts the
status flags, and stamps the block's first frame with a host monotonic time:

* ``"adc"``: PortAudio's ``inputBufferAdcTime`` (stream clock), mapped to ``time.monotonic``
  through the stream's ``currentTime`` read in the same callback (lower envelope of
  ``monotonic - currentTime``), then smoothed by a frame-count fit. Precise when the driver
  fills it in correctly (ALSA hardware).
* ``"frames"``: frame counts only: ``t(k) = t0 + k / rate``, ``t0`` and ``rate`` fitted to
  the lower envelope of (frame index, callback arrival - reported input latency). For
  sources whose ADC time is 0 or wrong: the ALSA pulse plugin reports a stream latency that
  jumps by half a second when playback starts on the sink.
  Forced (``timestamps="adc"``), blocks whose ADC time is unusable are counted and stamped
  from the best clock available (frames until the first good ADC time).
* ``"auto"`` (default): frames on ALSA plugin devices (``pulse``, ``default``: see
  :func:`adc_time_trusted`); elsewhere ADC times while every one is plausible (non-zero,
  latency under ``max_adc_latency``, advancing with the frame count), from the first bad
  one on, frames (counted in ``clock_steps`` when the two disagree by over 1 ms).
"""
from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from .chunk import AudioStats, Chunk
from ..clockfit import FrameClock
from .devices import InputDevice, find_input_device, import_sounddevice, supported_rates
from .source import AudioBackendError, AudioSettingsError, RingSource

log = logging.getLogger(__name__)

TIMESTAMP_MODES = ("auto", "adc", "frames")
SLEW = 5e-3
"""How fast chunk times may catch up with a clock fit that moved back (seconds per second):
5 ms per second of audio. A catching-up block is stamped with a host rate up to 0.5 % above
the fit's (its ``host_rate``), never with a start before the previous block's end."""
WARMUP_S = 4.0
WARMUP_SLEW = 0.25
"""In a stream's first ``WARMUP_S`` seconds of audio, chunk times catch up at up to 25 %.
The fit is young there: if the first callbacks came late (a busy host while the stream
opened, then the backlog in a burst), the first stamps are late by that stall and the fit
moves back when the burst arrives. At 0.5 % a 0.5 s stall would stay in the stamps for
100 s of audio; at 25 % it is gone after 2 s (up to 1 s of stall is caught up this way)."""


def adc_time_trusted(device: InputDevice) -> bool:
    """Whether ``"auto"`` tries PortAudio's ADC time on this device.

    Not on ALSA plugins (pulse, pipewire, default, dsnoop: no ``hw:N,M`` in the name): they
    report a sound server's latency estimate, which jumps by hundreds of milliseconds.
    """
    return not (device.hostapi == "ALSA" and device.alsa_card is None)


class SoundDeviceSource(RingSource):
    """Capture from a PortAudio input device.

    ``device``: None (default input), an index, or part of a device name (``"pulse"``,
    ``"USB Audio"``). ``dtype``: ``"int16"``, ``"int32"`` (use it for 24-bit cards: samples
    arrive left-aligned with the low byte zero) or ``"float32"``. ``blocksize`` 0 lets the
    driver choose (lowest latency). ``buffer_seconds`` sizes the ring buffer: a consumer that
    falls further behind loses the oldest frames, counted in ``stats.overruns_frames``.

    >>> with SoundDeviceSource("USB Audio", 44100, channels=1) as src:    # doctest: +SKIP
    ...     for chunk in src.chunks():
    ...         print(chunk.first_index, chunk.host_time, chunk.samples.shape)
    """

    def __init__(self, device: int | str | None = None, samplerate: float = 44100,
                 channels: int = 1, dtype: str = "int16", *, blocksize: int = 0,
                 latency: float | str = "low", buffer_seconds: float = 10.0,
                 timestamps: str = "auto", max_adc_latency: float = 0.25,
                 name: str | None = None) -> None:
        if timestamps not in TIMESTAMP_MODES:
            raise ValueError(f"timestamps must be one of {TIMESTAMP_MODES}, not {timestamps!r}")
        super().__init__(samplerate, channels, dtype, buffer_seconds,
                         name or f"sound device {device!r}")
        self.device = device
        self.blocksize = int(blocksize)
        self.latency_setting = latency
        self.timestamps = timestamps
        self.max_adc_latency = float(max_adc_latency)
        self.device_info = None
        self.latency = 0.0
        """Input latency PortAudio reports for the open stream (seconds)."""
        self._stream: Any = None
        self.clock: Callable[[], float] = time.monotonic
        """The host clock each block is stamped against, read in :meth:`callback`."""
        self._stopping = False
        self._reported: dict[str, int] = {}
        self._told_source = ""
        self._first_error: BaseException | None = None
        self._reset_timing()

    def _reset_timing(self) -> None:
        fs = self.sample_rate
        self._arrival_clock = FrameClock(fs)
        self._adc_clock = FrameClock(fs)
        self._stream_map = FrameClock(1.0)
        self._source = "frames" if self.timestamps == "frames" else "adc"
        self._adc_good = 0
        self._prev_adc_k = -1
        self._prev_adc = 0.0
        self._t_min = -math.inf
        self._rate = fs

    # --- start / stop ---------------------------------------------------------------------

    def start(self) -> SoundDeviceSource:
        if self._running:
            return self
        sd = import_sounddevice()
        dev = find_input_device(self.device)
        self.device_info = dev
        if self.channels > dev.max_input_channels:
            raise AudioSettingsError(f"{dev.describe()} has {dev.max_input_channels} input "
                                     f"channel(s); {self.channels} asked for")
        dtype = self.dtype.name
        try:
            sd.check_input_settings(device=dev.index, channels=self.channels, dtype=dtype,
                                    samplerate=self.sample_rate)
        except sd.PortAudioError as e:
            rates = supported_rates(dev.index, self.channels, dtype)
            raise AudioSettingsError(
                f"{dev.describe()} refuses {self.sample_rate:g} Hz, {self.channels} "
                f"channel(s), {dtype}: {e}; rates it accepts with these settings: "
                f"{', '.join(map(str, rates)) or 'none of the common ones'}") from e
        self._prepare(dev)
        try:
            stream = sd.InputStream(device=dev.index, samplerate=self.sample_rate,
                                    channels=self.channels, dtype=dtype,
                                    blocksize=self.blocksize, latency=self.latency_setting,
                                    callback=self.callback,
                                    finished_callback=self._on_finished)
        except sd.PortAudioError as e:
            raise AudioBackendError(f"cannot open {dev.describe()}: {e}") from e
        self.latency = float(stream.latency)  # before start: the callback reads it
        self._stream = stream
        self._running = True
        try:
            stream.start()
        except sd.PortAudioError as e:
            self._running = False
            stream.close(ignore_errors=True)
            self._stream = None
            raise AudioBackendError(f"cannot start {dev.describe()}: {e}") from e
        log.info("capturing from %s at %g Hz, %d channel(s), %s, input latency %.1f ms",
                 dev.describe(), self.sample_rate, self.channels, dtype, self.latency * 1e3)
        return self

    def start_external(self, dev: InputDevice) -> SoundDeviceSource:
        """Take blocks from a stream the caller runs on ``dev`` (its own PortAudio stream, or
        a test's hand-made blocks): pass each callback's arguments on to :meth:`callback`.
        :meth:`start` opens a stream of its own instead."""
        self._prepare(dev)
        self._running = True
        return self

    def _prepare(self, dev: InputDevice) -> None:
        """Fresh ring buffer, clocks and counters for a stream on ``dev``."""
        self._make_ring()
        self._reset_timing()
        if self.timestamps == "auto" and not adc_time_trusted(dev):
            self._source = "frames"
        self._st.timestamp_source = self._source
        self._reported = {}
        self._told_source = ""
        self._first_error = None
        self._stopping = False

    def stop(self) -> None:
        stream = self._stream
        if stream is None:
            return
        self._stopping = True
        try:
            stream.stop(ignore_errors=True)
            stream.close(ignore_errors=True)
        finally:
            self._stream = None
            self._set_finished()
            self._report()
        st = self.stats
        if st.input_overflows or st.overruns_frames or st.callback_errors or st.stream_errors:
            log.warning("%s: %d input overflows, %d frames overrun in the ring buffer, %d "
                        "callback errors, %d stream errors", self.name, st.input_overflows,
                        st.overruns_frames, st.callback_errors, st.stream_errors)

    def _on_finished(self) -> None:
        if not self._stopping:
            self._st.stream_errors += 1
        self._set_finished()

    # --- the audio callback (PortAudio's thread) ------------------------------------------

    def callback(self, indata: np.ndarray, frames: int, time_info: Any, status: Any) -> None:
        """PortAudio's input callback: copy the block into the ring buffer and stamp it."""
        now = self.clock()
        st = self._st
        try:
            if status:
                over = status.input_overflow
                under = status.input_underflow
                if over:
                    st.input_overflows += 1
                if under:
                    st.input_underflows += 1
                if over or under:
                    st.xruns += 1
            ring = self._ring
            k0 = ring.write_index
            t = self._stamp(k0, frames, time_info.inputBufferAdcTime,
                            time_info.currentTime, now)
            ring.write(indata, t, self._rate)
            st.frames += frames
            st.blocks += 1
            self._data.set()
        except Exception as e:  # never raise into PortAudio: that would end the stream
            st.callback_errors += 1
            if self._first_error is None:
                self._first_error = e

    def _adc_ok(self, k0: int, adc: float, cur: float) -> bool:
        if not (adc > 0.0 and cur > 0.0 and math.isfinite(adc) and math.isfinite(cur)):
            return False
        lat = cur - adc
        if lat < -1e-3 or lat > self.max_adc_latency:
            return False
        ok = True
        if self._prev_adc_k >= 0:
            expected = (k0 - self._prev_adc_k) / self.sample_rate
            ok = abs((adc - self._prev_adc) - expected) <= 1e-3 + 2e-3 * expected
        self._prev_adc_k = k0
        self._prev_adc = adc
        return ok

    def _stamp(self, k0: int, n: int, adc: float, cur: float, now: float) -> float:
        """Host time of frame ``k0``, the first of a block of ``n`` that arrived at ``now``."""
        self._arrival_clock.observe(k0 + n, now - self.latency)
        if self.timestamps == "adc" or self._source == "adc":
            if self._adc_ok(k0, adc, cur):
                self._adc_good += 1
                self._stream_map.observe(cur, now)
                self._adc_clock.observe(k0, self._stream_map.to_host(adc))
            else:
                self._st.adc_time_rejected += 1
                # Grace for the first two callbacks (some drivers start with 0).
                if (self.timestamps == "auto" and self._source == "adc"
                        and (self._adc_good > 0 or self._st.blocks >= 2)):
                    self._switch_to_frames(k0)
        clock = self._adc_clock
        if self._source != "adc" or not clock.ready:
            clock = self._arrival_clock
        t = clock.to_host(k0)
        rate = clock.rate
        if t < self._t_min:
            # A refit (or a switch of clock) moved the line back. The block starts where the
            # last one ended, so no frame is stamped before one digitised earlier, and its
            # frames come closer together, so that it ends at most SLEW (0.5 %) of its
            # duration early (WARMUP_SLEW while the stream is young): the stamps reach the
            # fit without ever going back, whichever frame a chunk starts at.
            slew = WARMUP_SLEW if k0 < WARMUP_S * self.sample_rate else SLEW
            end = max(clock.to_host(k0 + n), self._t_min + (1.0 - slew) * n / rate)
            t = self._t_min
            rate = n / (end - t)
        self._t_min = t + n / rate
        self._rate = rate
        return t

    def _switch_to_frames(self, k0: int) -> None:
        self._source = "frames"
        self._st.timestamp_source = "frames"
        if self._adc_clock.ready:
            gap = abs(self._adc_clock.to_host(k0) - self._arrival_clock.to_host(k0))
            if gap > 1e-3:
                self._st.clock_steps += 1

    # --- reading ----------------------------------------------------------------------------

    def read(self, max_frames: int | None = None, timeout: float | None = None,
             out: np.ndarray | None = None) -> Chunk | None:
        chunk = super().read(max_frames, timeout, out)
        self._report()
        return chunk

    def time_of(self, index: int) -> float:
        """Best current estimate (the latest clock fit; chunks carry the causal one)."""
        clock = self._adc_clock
        if self._source != "adc" or not clock.ready:
            clock = self._arrival_clock
        if not clock.ready:
            return super().time_of(index)
        return clock.to_host(index)

    @property
    def stats(self) -> AudioStats:
        st = super().stats
        clock = self._arrival_clock if self._source == "frames" else self._adc_clock
        st.clock_steps += clock.steps
        return st

    def _report(self) -> None:
        """Log what the callback counted (logging inside the callback could block it)."""
        st = self.stats
        rep = self._reported
        for key, what in (("input_overflows", "input overflow(s): the driver or server "
                                               "dropped frames"),
                          ("overruns_frames", "frame(s) overwritten in the ring buffer "
                                              "before they were read"),
                          ("callback_errors", "error(s) in the audio callback"),
                          ("stream_errors", "stream ended by itself (device gone?)"),
                          ("clock_steps", "step(s) of the audio clock")):
            value = getattr(st, key)
            if value >= 2 * rep.get(key, 0) and value:  # the first, then at each doubling
                rep[key] = value
                log.warning("%s: %d %s", self.name, value, what)
        if self._first_error is not None and not rep.get("first_error"):
            rep["first_error"] = 1
            log.error("%s: audio callback failed: %r", self.name, self._first_error)
        if st.blocks and st.timestamp_source != self._told_source:
            self._told_source = st.timestamp_source
            if st.adc_time_rejected:
                log.info("%s: timestamps from %s (%d ADC times rejected)", self.name,
                         st.timestamp_source, st.adc_time_rejected)
            else:
                log.info("%s: timestamps from %s", self.name, st.timestamp_source)
