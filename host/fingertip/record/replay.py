"""``Replay``: a recording played back as if it were a live fingertip.

A :class:`Replay` hands out the same :class:`~fingertip.Frame` objects, through the same
calls, as :class:`~fingertip.Fingertip` (``read``, ``frames``, iteration, ``drain``,
``add_callback``, ``start``/``stop``/``close``, ``status``, ``stats``, ``info``), and its
:meth:`Replay.audio` source hands out the same :class:`~fingertip.audio.Chunk` objects as a
live :class:`~fingertip.audio.AudioSource`. Code written against a device runs unchanged on
a recording. Commands that would change a device (tare, rate, gain, power) do not exist on
a replay.

Timing: at ``speed`` 1 each frame is delivered when its last byte arrived in the recording
(relative to the start of the replay) and each audio chunk when its last frame was
digitised; ``speed`` 2 plays twice as fast; ``speed=None`` as fast as the consumer takes
them: then a full frame queue makes the replay wait instead of dropping (unless frames
are only taken through callbacks and ``read`` is never called: then the queue overruns,
counted, as a live one does), and so does a full ring of a started audio source (read
it, or stop it).
Host times keep their recorded spacing; with ``rebase`` (default) they are all shifted by
one constant so that the first message's time is the moment the replay started, so that
they compare with ``time.monotonic()`` as live times do. ``rebase=False`` gives the
recording host's own monotonic times. Device times, sequence numbers, counts and masks are
exactly as recorded.
"""
from __future__ import annotations

import logging
import math
import os
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..audio import AudioStats, RingBuffer, RingSource
from ..device import BridgeStats, Frame, NotConnected
from ..device.frames import FrameSource
from ..protocol import Info, message_from_dict
from ..errors import BadArgumentError
from . import schemas as S
from .reader import Recording, RecordingError

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class Wrench:
    """Forces (N) and torques (N m) of one fingertip at ``host_time``."""

    name: str
    host_time: float
    force: tuple[float, float, float]
    torque: tuple[float, float, float]


@dataclass(frozen=True, slots=True)
class RecordedEvent:
    """An event of fingertip ``name``; ``time``, ``kind`` and ``value`` as in
    :class:`fingertip.events.Event` (``time``: host monotonic seconds, like
    ``Frame.host_time``)."""

    name: str
    time: float
    kind: str
    value: float
    detail: str = ""


class ReplayAudioSource(RingSource):
    """The recorded audio of one fingertip, as an :class:`~fingertip.audio.AudioSource`.

    Filled by its :class:`Replay` while it plays (start the source, then the replay). Frame
    indices are the recorded ones; frames lost during the recording come back as zeros (so
    that indices stay sample-exact), counted in ``Replay.audio_gap_frames``.
    """

    def __init__(self, replay: Replay, sample_rate: float, channels: int, dtype: str,
                 start_index: int, buffer_seconds: float) -> None:
        super().__init__(sample_rate, channels, dtype, buffer_seconds,
                         f"replay {replay.recording.path.name}:{replay.name}")
        self._replay = replay
        self._start_index = int(start_index)
        self._st.timestamp_source = "recorded"

    def start(self) -> ReplayAudioSource:
        if self._running:
            return self
        capacity = max(1, math.ceil(self.buffer_seconds * self.sample_rate))
        self._ring = RingBuffer(capacity, self.channels, self.dtype, self.sample_rate,
                                start_index=self._start_index)
        self._st = AudioStats(timestamp_source="recorded")
        self._finished = False
        self._data.clear()
        self._running = True
        if self._replay.ended:
            self._set_finished()
        return self

    def stop(self) -> None:
        if self._running:
            self._set_finished()

    def _feed(self, block: np.ndarray, first_index: int, host_time: float,
              host_rate: float, wait: bool) -> int:
        """Write a recorded chunk (zero-filling a gap before it). Returns gap frames."""
        ring = self._ring
        if ring is None or not self._running:
            return 0
        gap = first_index - ring.write_index
        if first_index < ring.write_index:  # overlaps what we have: keep the new part
            block = block[ring.write_index - first_index:]
            host_time += (ring.write_index - first_index) / host_rate
            first_index = ring.write_index
            gap = 0
        if gap > 0:
            zeros = np.zeros((gap, self.channels), dtype=self.dtype)
            self._wait_room(gap, wait)
            self._produce(zeros, host_time - gap / host_rate, host_rate)
        if len(block):
            self._wait_room(len(block), wait)
            self._produce(block, host_time, host_rate)
        return max(gap, 0)

    def _wait_room(self, n: int, wait: bool) -> None:
        ring = self._ring
        assert ring is not None
        while wait and self._running and not self._replay._stop_event.is_set() \
                and ring.available + n > ring.capacity:
            self._replay._stop_event.wait(0.001)

    def _end(self) -> None:
        if self._running:
            self._set_finished()


class Replay(FrameSource):
    """Play fingertip ``name`` of the recording at ``path`` (see the module's notes).

    >>> with Replay("run.mcap", speed=None) as ft:            # doctest: +SKIP
    ...     ft.start()
    ...     for frame in ft.frames(timeout=1.0):
    ...         print(frame.host_time, frame.counts)

    ``name`` may be omitted when the file holds one fingertip. ``speed``: 1.0 real time,
    2.0 twice as fast, None as fast as possible. ``window``: seconds of reordering
    (see :meth:`Recording.messages`).
    """

    def __init__(self, path: str | os.PathLike, name: str | None = None, *,
                 speed: float | None = 1.0, rebase: bool = True, queue_size: int = 4096,
                 block_when_full: bool | None = None, window: float = 2.0,
                 audio_buffer_seconds: float = 10.0) -> None:
        if speed is not None and not (speed > 0 and math.isfinite(speed)):
            raise BadArgumentError(f"speed must be a positive number (or None), not {speed}")
        if not (isinstance(queue_size, int) and queue_size >= 1):
            raise BadArgumentError(f"queue_size must be an integer >= 1, not {queue_size!r}")
        self.recording = rec = Recording(path)
        devices = rec.devices()
        if name is None:
            if not devices:
                raise RecordingError(f"{rec.path}: no fingertip frames in this file")
            if len(devices) > 1:
                raise RecordingError(f"{rec.path} holds several fingertips "
                                     f"({', '.join(devices)}): choose one by name")
            name = devices[0]
        elif name not in rec.names():
            raise RecordingError(f"{rec.path}: no fingertip named {name!r} (it holds: "
                                 f"{', '.join(rec.names()) or 'nothing'})")
        self.name = name
        self.port = str(rec.path)
        self.serial_number = None
        self.speed = speed
        self.rebase = rebase
        self.window = window
        self.block_when_full = (speed is None) if block_when_full is None else block_when_full
        self.audio_buffer_seconds = audio_buffer_seconds
        self._queue: deque[Frame] = deque(maxlen=queue_size)
        self._cond = threading.Condition()
        self._callbacks: list[Callable[[Frame], None]] = []
        self._wrench_callbacks: list[Callable[[Wrench], None]] = []
        self._event_callbacks: list[Callable[[RecordedEvent], None]] = []
        self._audio: ReplayAudioSource | None = None
        self._thread: threading.Thread | None = None
        self._stop_event = threading.Event()
        self._status = "closed"
        self._ended = False
        self._played_all = False
        self._info_json: dict[str, Any] | None = None
        self._counters = BridgeStats()
        self._reading = False
        self.frames_replayed = 0
        self.audio_gap_frames = 0
        self.shift = 0.0
        """Seconds added to every recorded host time (see ``rebase``)."""

    # --- life cycle (as Fingertip) --------------------------------------------------------

    def open(self) -> Replay:
        if self._status == "closed" and not self._ended:
            self._info_json = self.recording.info(self.name)
            self._status = "connected"
        return self

    def start(self) -> None:
        """Begin playing (once; a replay that has ended stays ended)."""
        if self._status == "closed" and not self._ended:
            self.open()
        if self._thread is not None or self._ended:
            return
        self._stop_event.clear()
        self._thread = threading.Thread(target=self._run, daemon=True,
                                        name=f"replay-{self.name}")
        self._thread.start()

    def stop(self) -> None:
        """Stop playing (frames already queued can still be read)."""
        self._stop_event.set()
        t = self._thread
        if t is not None and t is not threading.current_thread():
            t.join(timeout=5)

    def close(self) -> None:
        self.stop()
        self._end()

    def __enter__(self) -> Replay:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def wait(self, timeout: float | None = None) -> bool:
        """Wait until the whole recording has been played. True if it has."""
        t = self._thread
        if t is not None:
            t.join(timeout)
        return self._played_all

    # --- state ----------------------------------------------------------------------------

    @property
    def status(self) -> str:
        """``"connected"`` while open and playing, ``"closed"`` once played to the end."""
        return self._status

    @property
    def ended(self) -> bool:
        """Played to the end, or closed: no more frames will come."""
        return self._ended

    @property
    def info(self) -> Info:
        """The device's INFO as recorded."""
        d = self._info_json if self._info_json is not None else self.recording.info(self.name)
        self._info_json = d
        if not d or "info" not in d:
            raise NotConnected(f"{self.name}: the recording has no device INFO")
        return message_from_dict(d["info"])  # type: ignore[return-value]

    @property
    def info_json(self) -> dict[str, Any]:
        """Everything the recorder stored about the device (port, settings, INFO)."""
        if self._info_json is None:
            self._info_json = self.recording.info(self.name) or {}
        return self._info_json

    @property
    def channels(self) -> int:
        return self.info.channels

    @property
    def stats(self) -> BridgeStats:
        """Frames replayed (``frames_ok``), ``overruns`` of the frame queue and
        ``callback_errors``; the link counters of the recorded device are not replayed."""
        c = self._counters
        return BridgeStats(frames_ok=self.frames_replayed, overruns=c.overruns,
                           callback_errors=c.callback_errors)

    # --- frames (as Fingertip) ------------------------------------------------------------

    def read(self, timeout: float | None = None) -> Frame | None:
        self._reading = True
        with self._cond:
            if not self._queue:
                if self._status == "closed":
                    if not self._ended:  # a loop on it would spin on None for ever
                        raise NotConnected(f"replay of {self.recording.path} was never "
                                           f"opened: call open() or start() first (or use "
                                           f"`with Replay(...)`)")
                    return None
                self._cond.wait(timeout)
            if self._queue:
                f = self._queue.popleft()
                self._cond.notify_all()
                return f
            return None

    def drain(self) -> list[Frame]:
        with self._cond:
            out = list(self._queue)
            self._queue.clear()
            self._cond.notify_all()
        return out

    def add_wrench_callback(self, fn: Callable[[Wrench], None]) -> None:
        """Recorded forces (``/fingertip/<name>/wrench``), as they come."""
        self._wrench_callbacks.append(fn)

    def add_event_callback(self, fn: Callable[[RecordedEvent], None]) -> None:
        """Recorded events (``/fingertip/<name>/events``), as they come."""
        self._event_callbacks.append(fn)

    # --- audio ----------------------------------------------------------------------------

    def audio(self) -> ReplayAudioSource:
        """The recorded audio of this fingertip as an audio source (create it, and start
        it, before starting the replay)."""
        if self._audio is not None:
            return self._audio
        ch = self.recording.channels().get(S.topic(self.name, "audio"))
        first = next(iter(self.recording.records(kinds=("audio",), names=(self.name,))),
                     None)
        if ch is None or first is None:
            raise RecordingError(f"{self.recording.path}: no audio recorded for {self.name}")
        m: S.AudioMsg = first.msg
        dtype = S.AUDIO_DTYPES.get(m.encoding)
        if dtype is None:
            raise RecordingError(f"{self.recording.path}: unknown audio encoding {m.encoding}")
        self._audio = ReplayAudioSource(self, m.sample_rate, m.channels, dtype, m.first_index,
                                        self.audio_buffer_seconds)
        return self._audio

    # --- the replay thread ----------------------------------------------------------------

    def _run(self) -> None:
        tb = self.recording.timebase
        t0 = time.monotonic()
        first_ns: int | None = None
        try:
            for r in self.recording.messages(("raw", "wrench", "audio", "events"),
                                             (self.name,), self.window):
                if self._stop_event.is_set():
                    return
                if first_ns is None:
                    first_ns = r.log_time
                    self.shift = (t0 - tb.to_monotonic(first_ns)) if self.rebase else 0.0
                if self.speed is not None:
                    due = t0 + (self._available_ns(r) - first_ns) / S.NS / self.speed
                    delay = due - time.monotonic()
                    if delay > 0 and self._stop_event.wait(delay):
                        return
                self._dispatch(r)
        except Exception:
            log.exception("%s: replay failed", self.name)
        finally:
            if not self._stop_event.is_set():
                self._played_all = True
                self._end()

    @staticmethod
    def _available_ns(r) -> int:
        m = r.msg
        if r.kind == "raw":
            return m.arrival_ns
        if r.kind == "audio" and m.host_rate > 0:
            return r.log_time + round(m.frames / m.host_rate * S.NS)
        return r.log_time

    def _time(self, ns: int) -> float:
        return self.recording.timebase.to_monotonic(ns) + self.shift

    def _dispatch(self, r) -> None:
        m = r.msg
        if r.kind == "raw":
            self._on_frame(Frame(m.seq, m.device_time_us, self._time(m.stamp_ns),
                                 self._time(m.arrival_ns), tuple(m.counts), m.timeout_mask,
                                 m.saturation_mask))
        elif r.kind == "audio":
            src = self._audio
            if src is not None and src.running:
                dtype = np.dtype(S.AUDIO_DTYPES[m.encoding]).newbyteorder("<")
                block = np.frombuffer(m.data, dtype=dtype).reshape(m.frames, m.channels)
                self.audio_gap_frames += src._feed(block, m.first_index, self._time(m.stamp_ns),
                                                   m.host_rate, self.block_when_full)
        elif r.kind == "wrench":
            w = Wrench(self.name, self._time(m.stamp_ns), m.force, m.torque)
            for cb in self._wrench_callbacks:
                self._call(cb, w)
        elif r.kind == "events":
            e = RecordedEvent(self.name, self._time(m.stamp_ns), m.kind, m.value, m.detail)
            for cb in self._event_callbacks:
                self._call(cb, e)

    def _on_frame(self, frame: Frame) -> None:
        self.frames_replayed += 1
        with self._cond:
            if self.block_when_full and (self._reading or not self._callbacks):
                while len(self._queue) == self._queue.maxlen and \
                        not self._stop_event.is_set():
                    self._cond.wait(0.05)
            if len(self._queue) == self._queue.maxlen:
                self._counters.overruns += 1
            self._queue.append(frame)
            self._cond.notify_all()
        for cb in self._callbacks:
            self._call(cb, frame)

    def _call(self, cb, arg) -> None:
        try:
            cb(arg)
        except Exception:
            self._counters.callback_errors += 1
            log.exception("%s: replay callback failed", self.name)

    def _end(self) -> None:
        self._ended = True
        with self._cond:
            self._status = "closed"
            self._cond.notify_all()
        if self._audio is not None:
            self._audio._end()
