"""``Recorder``: fingertip frames, forces, audio and events into one MCAP file (ROS 2 CDR).

Producers (a :class:`~fingertip.Fingertip`'s reader thread through a callback, an audio
thread, user code) hand messages to :meth:`Recorder.write_frame`, :meth:`write_audio`,
:meth:`write_event`... which never block and never raise for I/O: they put the message on a
bounded queue (or count it as dropped when the queue is full or the recorder has failed).
One writer thread encodes (CDR), writes chunks and finishes the file. Every
``flush_interval`` seconds, or when a chunk reaches ``flush_bytes``, the chunk in progress
is closed and written to the OS: a process killed with SIGKILL leaves a file readable up to
its last flushed chunk (see :class:`~fingertip.record.reader.Recording`).

A write error (disk full, device gone) stops the writer cleanly: the error is kept in
:attr:`Recorder.error`, later messages count as dropped, nothing hangs.

This module is the API and the bookkeeping of the sources; the queue and writer thread are
:mod:`.writer`, the file :mod:`.sink`, the messages :mod:`.encoding`, the audio threads
:mod:`.audio_pump`.
"""
from __future__ import annotations

import json
import os
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, is_dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__
from ..audio import AudioSource, Chunk
from ..device import Fingertip, Frame
from ..protocol import message_to_dict
from . import schemas as S
from .audio_pump import pump_thread
from .encoding import ForceModel, audio_payload, device_info, xyz
from .stats import RecorderError, RecorderStats
from .timebase import TimeBase
from .writer import COMPRESSIONS, METADATA_NAME, RecordWriter

FORMAT = "fingertip-recording/1"

__all__ = ["FORMAT", "METADATA_NAME", "ForceModel", "Recorder", "RecorderError",
           "RecorderStats"]


@dataclass
class _Device:
    name: str
    force_model: ForceModel | None = None
    fingertip: Fingertip | None = None
    callback: Callable[[Frame], None] | None = None


@dataclass
class _AudioStream:
    name: str
    metadata: dict[str, str]


class Recorder:
    """Record one or more fingertips (and their microphones) into ``path`` (MCAP).

    >>> with Recorder("run.mcap") as rec, Fingertip("/dev/ttyACM0") as ft:  # doctest: +SKIP
    ...     rec.attach(ft, name="index")
    ...     ft.start()
    ...     time.sleep(10)

    ``flush_interval`` (seconds) and ``flush_bytes`` bound what a crash can lose: the chunk
    in progress is written when either is reached. ``queue_size`` messages may wait for the
    writer; more are dropped and counted. ``fsync`` also asks the OS to put each flushed
    chunk on the disk (needed against power loss, not against a killed process).
    ``overwrite``: replace an existing file (otherwise that is an error).
    """

    def __init__(self, path: str | os.PathLike, *, flush_interval: float = 0.5,
                 flush_bytes: int = 1 << 20, queue_size: int = 20000,
                 compression: str = "zstd", fsync: bool = False,
                 overwrite: bool = False, metadata: dict[str, str] | None = None) -> None:
        if not 0 < flush_interval < float("inf"):
            raise ValueError(f"flush_interval must be a positive number of seconds, not "
                             f"{flush_interval!r}")
        if not (isinstance(queue_size, int) and queue_size >= 1):
            raise ValueError(f"queue_size must be an integer >= 1, not {queue_size!r}")
        if flush_bytes < 1024:
            raise ValueError("flush_bytes must be at least 1024")
        if compression not in COMPRESSIONS:
            raise ValueError(f"compression must be one of {', '.join(COMPRESSIONS)}")
        self.path = Path(path)
        self.flush_interval = float(flush_interval)
        self.flush_bytes = int(flush_bytes)
        self.compression = compression
        self.fsync = fsync
        self.overwrite = overwrite
        self.extra_metadata = dict(metadata or {})
        self.timebase = TimeBase.measure()
        self._devices: dict[str, _Device] = {}
        self._audio: dict[str, _AudioStream] = {}
        self._writer = RecordWriter(
            self.path, queue_size=queue_size, flush_interval=self.flush_interval,
            flush_bytes=self.flush_bytes, compression=compression, fsync=fsync,
            overwrite=overwrite, timebase=self.timebase, force_model_of=self._force_model_of,
            audio_metadata_of=self._audio_metadata_of, link_counters=self._link_counters)
        self._pumps: list[threading.Thread] = []
        # Set first by close(): the audio pumps end and record what their sources captured
        # before the writer's closing refuses further writes (closing it first counted those
        # last chunks as dropped whenever a pump was behind, as under CPU load).
        self._pumps_stop = threading.Event()
        self._state = "new"
        self._early: list[tuple[str, tuple]] = []  # infos of devices added before start()
        self.start_monotonic = 0.0
        self.stop_monotonic: float | None = None

    # --- life cycle -----------------------------------------------------------------------

    def start(self) -> Recorder:
        """Create the file and write its header; start the writer thread.

        Raises :class:`RecorderError` when the file cannot be created or written.
        """
        if self._state == "closed":
            raise RecorderError(f"the recorder of {self.path} is closed: a closed recorder "
                                "cannot start again (make a new Recorder)")
        if self._state != "new":
            return self
        self._writer.create()
        self.start_monotonic = time.monotonic()
        start_ns = self.timebase.to_ns(self.start_monotonic)
        meta = {
            "format": FORMAT,
            "fingertip_version": __version__,
            "monotonic_to_unix_ns": str(self.timebase.offset_ns),
            "start_monotonic_ns": str(round(self.start_monotonic * S.NS)),
            "start_unix_ns": str(start_ns),
            "time": "header.stamp = log_time = host time.monotonic() + "
                    "monotonic_to_unix_ns, in Unix-epoch nanoseconds",
            "flush_interval_s": repr(self.flush_interval),
            "flush_bytes": str(self.flush_bytes),
        }
        meta.update({str(k): str(v) for k, v in self.extra_metadata.items()})
        self._writer.begin(meta)
        self._state = "running"
        for topic_name, item in self._early:
            self._put(topic_name, item)
        self._early.clear()
        self._writer.start()
        return self

    def close(self, timeout: float = 10.0) -> RecorderStats:
        """Stop: detach from devices and audio, write what is queued, finish the file.

        Never hangs longer than ``timeout`` (a writer stuck in the OS is abandoned and
        reported in :attr:`error`). Returns the final counters.
        """
        if self._state == "new":
            self._state = "closed"
            return self.stats
        if self._state == "closed":
            return self.stats
        self.stop_monotonic = time.monotonic()
        for dev in self._devices.values():
            if dev.fingertip is not None and dev.callback is not None:
                try:
                    dev.fingertip.remove_callback(dev.callback)
                except ValueError:
                    pass
        self._pumps_stop.set()
        deadline = time.monotonic() + timeout
        for t in self._pumps:
            t.join(timeout=max(0.0, min(1.0, deadline - time.monotonic())))
        self._writer.close(deadline, timeout, self.stop_monotonic)
        self._state = "closed"
        return self.stats

    def __enter__(self) -> Recorder:
        return self.start()

    def __exit__(self, exc_type, exc, tb) -> None:
        self.close()
        if exc_type is None and self._writer.error is not None:
            raise self._writer.error

    # --- state ----------------------------------------------------------------------------

    @property
    def error(self) -> RecorderError | None:
        """Why writing failed, or None."""
        return self._writer.error

    @property
    def failed(self) -> bool:
        return self._writer.error is not None

    @property
    def running(self) -> bool:
        return self._state == "running" and self._writer.error is None

    @property
    def stats(self) -> RecorderStats:
        return self._writer.stats

    @property
    def names(self) -> list[str]:
        return sorted(set(self._devices) | set(self._audio))

    # --- sources --------------------------------------------------------------------------

    def add_device(self, name: str, *, info: Any = None, force_model: ForceModel | None = None,
                   device: Any = None) -> None:
        """Declare a fingertip ``name`` (its topics are ``/fingertip/<name>/...``).

        ``info``: what the device reports (a protocol ``Info``, or any JSON-able dict),
        written once on ``/fingertip/<name>/info``. ``force_model``: counts -> forces, run
        on the writer thread for every frame and written on ``/fingertip/<name>/wrench``.
        ``device``: the :class:`Fingertip` whose link counters (``stats``) the file's summary
        keeps at the end (:meth:`attach` gives it).
        """
        S.check_name(name)
        if self._state == "closed":
            raise RecorderError(f"cannot add {name!r}: the recorder of {self.path} is closed")
        if name in self._devices:
            raise ValueError(f"a fingertip named {name!r} is already being recorded")
        self._devices[name] = _Device(name, force_model, device)
        if info is not None:
            self.write_info(name, info)

    def attach(self, fingertip: Fingertip, name: str | None = None, *,
               force_model: ForceModel | None = None) -> str:
        """Record every frame of an open ``fingertip`` (through a frame callback) under
        ``name`` (default: the fingertip's name if it makes a topic name, else
        ``"fingertip"``). Returns the name used."""
        if name is None:
            try:
                name = S.check_name(fingertip.name)
            except ValueError:
                name = "fingertip"
        self.add_device(name, info=device_info(fingertip, name), force_model=force_model)
        dev = self._devices[name]
        dev.fingertip = fingertip
        dev.callback = lambda frame, _n=name: self._write_frame(_n, frame)
        fingertip.add_callback(dev.callback)
        return name

    def add_audio(self, name: str, *, sample_rate: float, channels: int, dtype: str,
                  subtype: str | None = None, source: str = "") -> None:
        """Declare the audio stream of fingertip ``name`` (optional: the first chunk
        declares it too). ``subtype`` (e.g. ``PCM_24``) is kept for WAV export."""
        S.check_name(name)
        dt = np.dtype(dtype).name
        if dt not in S.AUDIO_ENCODINGS:
            raise ValueError(f"audio dtype {dt} is not int16, int32 or float32")
        meta = {"sample_rate": repr(float(sample_rate)), "channels": str(int(channels)),
                "dtype": dt, "encoding": S.AUDIO_ENCODINGS[dt], "source": source}
        if subtype:
            meta["subtype"] = subtype
        self._audio[name] = _AudioStream(name, meta)

    def record_audio(self, source: AudioSource, name: str = "fingertip", *,
                     max_seconds: float = 0.1) -> threading.Thread:
        """Read ``source`` (started here if it is not running) on a thread and record its
        chunks until the recorder closes or the source ends. The recorder becomes the
        source's consumer: to use the audio yourself too, read it and call
        :meth:`write_audio`."""
        if name not in self._audio:
            self.add_audio(name, sample_rate=source.sample_rate, channels=source.channels,
                           dtype=source.dtype.name, subtype=getattr(source, "subtype", None),
                           source=source.name)
        return self._pump(source, name, lambda chunk: self._write_audio(name, chunk),
                          max_seconds)

    def record_audio_split(self, source: AudioSource, names: Sequence[str], *,
                           max_seconds: float = 0.1) -> threading.Thread:
        """As :meth:`record_audio` for a multi-channel source whose channel k is the
        microphone of fingertip ``names[k]`` (one 4-input interface for a hand): each
        channel is recorded on its own fingertip's audio topic."""
        if source.channels < len(names):
            raise ValueError(f"{source.name} has {source.channels} channel(s) for "
                             f"{len(names)} fingertips")
        for name in names:
            if name not in self._audio:
                self.add_audio(name, sample_rate=source.sample_rate, channels=1,
                               dtype=source.dtype.name,
                               subtype=getattr(source, "subtype", None), source=source.name)

        def write(chunk: Chunk) -> None:
            for k, name in enumerate(names):
                self._write_audio(name, replace(chunk, samples=chunk.samples[:, k:k + 1]))
        return self._pump(source, names[0], write, max_seconds)

    def _pump(self, source: AudioSource, name: str, write: Callable[[Chunk], object],
              max_seconds: float) -> threading.Thread:
        t = pump_thread(source, name, write, max_seconds, self._pumps_stop,
                        lambda e: self._write_event(name, "audio_error", 0.0, detail=str(e)))
        self._pumps.append(t)
        t.start()
        return t

    # --- writing (any thread, never blocks) -----------------------------------------------

    def _put(self, topic_name: str, item: tuple) -> bool:
        return self._writer.put(topic_name, item)

    def _check_order(self, what: str) -> None:
        """Writing before start() or after close() is a mistake in the caller's order:
        say so (a failed recorder still accepts and counts writes, as documented)."""
        if self._state == "new":
            raise RecorderError(f"{what} before start(): start the recorder first (or use "
                                f"`with Recorder(...)`)")
        if self._state == "closed":
            raise RecorderError(f"{what} after close(): {self.path} is finished")

    def write_frame(self, name: str, frame: Frame) -> bool:
        """Queue a frame of fingertip ``name``. False if it was dropped."""
        self._check_order("write_frame")
        return self._write_frame(name, frame)

    def _write_frame(self, name: str, frame: Frame) -> bool:
        # The device callback's path: it may race with close() and must never raise there.
        if name not in self._devices:
            self.add_device(name)
        return self._put(S.topic(name, "raw"), ("raw", name, frame))

    def write_wrench(self, name: str, host_time: float, force: Sequence[float],
                     torque: Sequence[float] = (0.0, 0.0, 0.0)) -> bool:
        """Queue forces (N) and torques (N m) of fingertip ``name`` at monotonic
        ``host_time`` (for forces from your own model; see ``force_model`` otherwise)."""
        self._check_order("write_wrench")
        return self._put(S.topic(name, "wrench"),
                         ("wrench", name, host_time, xyz(force), xyz(torque)))

    def write_audio(self, name: str, chunk: Chunk) -> bool:
        """Queue an audio chunk of fingertip ``name`` (its samples are copied now)."""
        self._check_order("write_audio")
        return self._write_audio(name, chunk)

    def _write_audio(self, name: str, chunk: Chunk) -> bool:
        topic_name = S.topic(name, "audio")
        payload = audio_payload(chunk.samples)
        if payload is None:
            self._writer.count_drop(topic_name)
            self._writer.tell_once(f"audio-dtype-{name}", "audio %s: dtype %s cannot be "
                                   "recorded (int16, int32 or float32)", name,
                                   np.asarray(chunk.samples).dtype)
            return False
        encoding, data = payload
        if name not in self._audio:
            self.add_audio(name, sample_rate=chunk.sample_rate, channels=chunk.channels,
                           dtype=S.AUDIO_DTYPES[encoding])
        return self._put(topic_name, ("audio", name, chunk.host_time, chunk.first_index,
                                      chunk.frames, chunk.channels, chunk.sample_rate,
                                      chunk.host_rate, chunk.lost_before, encoding, data))

    def write_event(self, name: str, kind: str, value: float = 0.0, *,
                    host_time: float | None = None, detail: str = "") -> bool:
        """Queue an event of fingertip ``name`` at monotonic ``host_time`` (default: now)."""
        S.check_name(name)
        self._check_order("write_event")
        return self._write_event(name, kind, value, host_time=host_time, detail=detail)

    def _write_event(self, name: str, kind: str, value: float = 0.0, *,
                     host_time: float | None = None, detail: str = "") -> bool:
        t = time.monotonic() if host_time is None else host_time
        return self._put(S.topic(name, "events"),
                         ("event", name, t, str(kind), float(value), str(detail)))

    def write_events(self, name: str, events: Iterable[Any]) -> int:
        """Queue events of the events layer (:class:`fingertip.events.Event`: ``time`` in
        host monotonic seconds, ``kind``, ``value``). Returns how many were queued."""
        return sum(self.write_event(name, e.kind, getattr(e, "value", 0.0),
                                    host_time=e.time, detail=getattr(e, "detail", ""))
                   for e in events)

    def write_info(self, name: str, info: Any, host_time: float | None = None) -> bool:
        """Queue a JSON description of fingertip ``name`` (``/fingertip/<name>/info``)."""
        if self._state == "closed":
            self._check_order("write_info")
        if hasattr(info, "__dataclass_fields__") and hasattr(info, "TYPE"):
            info = message_to_dict(info)
        text = info if isinstance(info, str) else json.dumps(info, default=str)
        t = time.monotonic() if host_time is None else host_time
        if self._state == "new":  # a device declared before start(): written at start
            self._early.append((S.topic(name, "info"), ("info", name, t, text)))
            return True
        return self._put(S.topic(name, "info"), ("info", name, t, text))

    def write_encoded(self, name: str, kind: str, log_ns: int, data: bytes) -> bool:
        """Queue a message already encoded as ROS 2 CDR (e.g. received from the network) on
        ``/fingertip/<name>/<kind>``, logged at ``log_ns`` (Unix-epoch nanoseconds)."""
        topic_name = S.topic(S.check_name(name), kind)
        return self._put(topic_name, ("encoded", name, kind, int(log_ns), bytes(data)))

    def flush(self, timeout: float = 5.0) -> bool:
        """Write everything queued so far and close the chunk in progress. True when done."""
        self._check_order("flush")
        done = threading.Event()
        if not self._put("(flush)", ("flush", done)):
            return False
        return done.wait(timeout)

    # --- what the writer thread looks up --------------------------------------------------

    def _link_counters(self) -> dict[str, dict[str, int]]:
        """Each recorded fingertip's link counters now, for the file's summary."""
        return {n: asdict(d.fingertip.stats) for n, d in self._devices.items()
                if is_dataclass(getattr(d.fingertip, "stats", None))}

    def _force_model_of(self, name: str) -> ForceModel | None:
        dev = self._devices.get(name)
        return dev.force_model if dev is not None else None

    def _audio_metadata_of(self, name: str) -> dict[str, str] | None:
        stream = self._audio.get(name)
        return stream.metadata if stream else None
