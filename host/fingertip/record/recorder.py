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
"""
from __future__ import annotations

import errno
import json
import logging
import math
import os
import queue
import stat
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field, is_dataclass, replace
from pathlib import Path
from struct import error as struct_error
from typing import Any

import numpy as np
from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter

from .. import __version__
from ..audio import AudioSource, Chunk
from ..device import Fingertip, Frame
from ..protocol import message_to_dict
from . import schemas as S
from .timebase import TimeBase

log = logging.getLogger(__name__)

ForceModel = Callable[[Sequence[int]], Sequence[float]]
"""Raw counts of one frame -> ``(fx, fy)`` or ``(fx, fy, fz)`` in newtons."""

METADATA_NAME = "fingertip"
SUMMARY_METADATA_NAME = "fingertip.summary"
FORMAT = "fingertip-recording/1"
COMPRESSIONS = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4,
                "none": CompressionType.NONE}


class RecorderError(RuntimeError):
    """The recording cannot start, or writing it failed (the message says why and where)."""


@dataclass
class RecorderStats:
    """Counters of a recorder (a snapshot)."""

    accepted: dict[str, int] = field(default_factory=dict)
    """Messages accepted into the queue, by topic (written soon, or lost to a failure)."""
    written: dict[str, int] = field(default_factory=dict)
    """Messages in chunks written to the file, by topic (those of the chunk in progress
    count once it is written)."""
    dropped: dict[str, int] = field(default_factory=dict)
    """Messages not written (queue full; or lost to a write error: then the chunk in
    progress, what was queued, and everything after), by topic."""
    bytes_written: int = 0
    """Bytes handed to the OS so far (the file size)."""
    flushes: int = 0
    """Chunks closed and written."""
    queue_high_water: int = 0
    encode_errors: int = 0
    """Messages that could not be encoded (bad values), or force-model failures."""
    audio_frames: dict[str, int] = field(default_factory=dict)
    """Audio frames handed to the file (including the chunk in progress), by name."""

    @property
    def dropped_total(self) -> int:
        return sum(self.dropped.values())

    @property
    def written_total(self) -> int:
        return sum(self.written.values())


class _Sink:
    """Unbuffered file for the MCAP writer: every record it writes reaches the OS at once."""

    def __init__(self, fd: int, fsync: bool) -> None:
        self.fd = fd
        self.pos = 0
        self.fsync = fsync

    def write(self, data: bytes | bytearray | memoryview) -> int:
        view = memoryview(data)
        total = len(view)
        while view:
            n = os.write(self.fd, view)
            if n <= 0:  # pragma: no cover - os.write raises rather than return 0 on files
                raise OSError(errno.EIO, "write returned 0")
            view = view[n:]
            self.pos += n
        return total

    def tell(self) -> int:
        return self.pos

    def flush(self) -> None:
        if self.fsync:
            try:
                os.fsync(self.fd)
            except OSError as e:
                if e.errno not in (errno.EINVAL, errno.EROFS):  # not a regular file
                    raise

    def close(self) -> None:
        os.close(self.fd)


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


_STOP = object()


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
        self._queue: queue.Queue = queue.Queue(maxsize=queue_size)
        self._lock = threading.Lock()
        self._stats = RecorderStats()
        self._devices: dict[str, _Device] = {}
        self._audio: dict[str, _AudioStream] = {}
        self._pumps: list[threading.Thread] = []
        self._sink: _Sink | None = None
        self._mcap: McapWriter | None = None
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._channel_seq: Counter[str] = Counter()
        self._pending: Counter[str] = Counter()
        self._thread: threading.Thread | None = None
        self._closing = threading.Event()
        # Set first by close(): the audio pumps end and record what their sources captured
        # before _closing refuses further writes (setting _closing first counted those last
        # chunks as dropped whenever a pump was behind, as under CPU load).
        self._pumps_stop = threading.Event()
        self._state = "new"
        self._error: RecorderError | None = None
        self._told: set[str] = set()
        self._early: list[tuple[str, tuple]] = []  # infos of devices added before start()
        self._created = False
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
        fd = self._open_file()
        self._sink = _Sink(fd, self.fsync)
        self.start_monotonic = time.monotonic()
        try:
            self._mcap = McapWriter(self._sink, chunk_size=self.flush_bytes,
                                    compression=COMPRESSIONS[self.compression])
            self._mcap.start(profile="ros2",
                             library=f"fingertip/{__version__} (mcap-python, ROS 2 CDR)")
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
            self._mcap.add_metadata(METADATA_NAME, meta)
            self._sink.flush()
        except OSError as e:
            self._close_sink()
            if self._created:  # do not leave an empty, unreadable file behind
                try:
                    self.path.unlink()
                except OSError:
                    pass
            raise self._io_error(e, "cannot write") from e
        self._state = "running"
        for topic_name, item in self._early:
            self._put(topic_name, item)
        self._early.clear()
        self._thread = threading.Thread(target=self._run, daemon=True,
                                        name=f"recorder-{self.path.name}")
        self._thread.start()
        return self

    def _open_file(self) -> int:
        p = self.path
        try:
            st = p.stat()
        except FileNotFoundError:
            st = None
        except OSError as e:
            raise self._io_error(e, "cannot record to") from e
        if st is not None and stat.S_ISDIR(st.st_mode):
            raise RecorderError(f"cannot record to {p}: it is a directory; give a file name "
                                "such as run.mcap")
        regular = st is None or stat.S_ISREG(st.st_mode)
        if st is not None and regular and not self.overwrite:
            raise RecorderError(f"{p} already exists (choose another name, or overwrite it "
                                "explicitly)")
        flags = os.O_WRONLY | os.O_CREAT | getattr(os, "O_CLOEXEC", 0)
        if regular:
            flags |= os.O_TRUNC
        if st is None and not self.overwrite:
            flags |= os.O_EXCL  # it must not appear between the check and the open
        self._created = st is None
        try:
            return os.open(p, flags, 0o644)
        except FileExistsError as e:
            raise RecorderError(f"{p} already exists (choose another name, or overwrite it "
                                "explicitly)") from e
        except OSError as e:
            raise self._io_error(e, "cannot create") from e

    def _io_error(self, e: OSError, what: str) -> RecorderError:
        reason = e.strerror or str(e)
        hint = ""
        if e.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
            hint = " (the disk or quota is full, or the file hit a size limit)"
        elif e.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
            hint = " (no permission to write there)"
        elif e.errno == errno.ENOENT:
            hint = f" (the folder {self.path.parent} does not exist)"
        return RecorderError(f"{what} {self.path}: {reason}{hint}")

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
        self._closing.set()
        thread = self._thread
        if thread is not None:
            thread.join(timeout=max(0.0, deadline - time.monotonic()))
            if thread.is_alive():
                self._fail(RecorderError(f"writing {self.path} did not finish within "
                                         f"{timeout:.0f} s (is the disk stuck?)"))
        self._state = "closed"
        return self.stats

    def __enter__(self) -> Recorder:
        return self.start()

    def __exit__(self, exc_type, exc, tb) -> None:
        self.close()
        if exc_type is None and self._error is not None:
            raise self._error

    # --- state ----------------------------------------------------------------------------

    @property
    def error(self) -> RecorderError | None:
        """Why writing failed, or None."""
        return self._error

    @property
    def failed(self) -> bool:
        return self._error is not None

    @property
    def running(self) -> bool:
        return self._state == "running" and self._error is None

    @property
    def stats(self) -> RecorderStats:
        with self._lock:
            s = self._stats
            return RecorderStats(dict(s.accepted), dict(s.written), dict(s.dropped),
                                 self._sink.pos if self._sink else 0, s.flushes,
                                 s.queue_high_water, s.encode_errors, dict(s.audio_frames))

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

    def _pump(self, source: AudioSource, name: str, write, max_seconds: float
              ) -> threading.Thread:
        if not source.running and not source.finished:
            source.start()
        max_frames = max(1, int(source.sample_rate * max_seconds))

        def pump() -> None:
            try:
                while not self._pumps_stop.is_set():
                    chunk = source.read(max_frames, timeout=0.05)
                    if chunk is None:
                        if source.finished:
                            break
                        continue
                    write(chunk)
                # What was captured before the stop is still recorded.
                while (chunk := source.read(max_frames, timeout=0)) is not None:
                    write(chunk)
            except Exception as e:  # a broken source must not kill the recording silently
                log.error("audio %s: %s", name, e)
                self._write_event(name, "audio_error", 0.0, detail=str(e))

        t = threading.Thread(target=pump, daemon=True, name=f"recorder-audio-{name}")
        self._pumps.append(t)
        t.start()
        return t

    # --- writing (any thread, never blocks) -----------------------------------------------

    def _put(self, topic_name: str, item: tuple) -> bool:
        if self._state != "running" or self._error is not None or self._closing.is_set():
            self._count_drop(topic_name)
            return False
        try:
            self._queue.put_nowait(item)
        except queue.Full:
            self._count_drop(topic_name)
            return False
        n = self._queue.qsize()
        with self._lock:
            a = self._stats.accepted
            a[topic_name] = a.get(topic_name, 0) + 1
            if n > self._stats.queue_high_water:
                self._stats.queue_high_water = n
        return True

    def _count_drop(self, topic_name: str) -> None:
        with self._lock:
            d = self._stats.dropped
            d[topic_name] = d.get(topic_name, 0) + 1

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
            self._count_drop(topic_name)
            self._tell_once(f"audio-dtype-{name}", "audio %s: dtype %s cannot be recorded "
                            "(int16, int32 or float32)", name, np.asarray(chunk.samples).dtype)
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

    # --- writer thread --------------------------------------------------------------------

    def _run(self) -> None:
        next_flush = time.monotonic() + self.flush_interval
        q = self._queue
        try:
            while True:
                wait = min(0.1, max(0.0, next_flush - time.monotonic()))
                try:
                    item = q.get(timeout=wait) if wait > 0 else q.get_nowait()
                except queue.Empty:
                    item = None
                if item is not None:
                    self._handle(item)
                now = time.monotonic()
                if now >= next_flush:
                    self._flush()
                    next_flush = now + self.flush_interval
                if item is None and self._closing.is_set() and q.empty():
                    break
            self._finish()
        except OSError as e:
            self._fail(self._io_error(e, "writing failed:"))
        except Exception as e:  # a bug must still leave a clear error, not a dead thread
            log.exception("recorder writer failed")
            self._fail(RecorderError(f"recording to {self.path} failed: {e}"))

    def _fail(self, err: RecorderError) -> None:
        if self._error is None:
            self._error = err
            # Reported by whoever owns the recorder (``error``, ``__exit__``, the CLI).
            log.debug("%s", err)
        # The unwritten chunk and what is still queued are lost: count them as dropped.
        with self._lock:
            for t, n in self._pending.items():
                self._stats.dropped[t] = self._stats.dropped.get(t, 0) + n
        self._pending.clear()
        while True:
            try:
                item = self._queue.get_nowait()
            except queue.Empty:
                break
            if item[0] == "flush":
                item[1].set()
            else:
                kind = {"event": "events", "encoded": item[2]}.get(item[0], item[0])
                self._count_drop(S.topic(item[1], kind))
        self._close_sink()

    def _close_sink(self) -> None:
        sink = self._sink
        if sink is not None and getattr(sink, "fd", -1) >= 0:
            try:
                sink.close()
            except OSError:
                pass
            sink.fd = -1

    def _tell_once(self, key: str, msg: str, *args: Any) -> None:
        if key not in self._told:
            self._told.add(key)
            log.warning(msg, *args)

    def _flush(self) -> None:
        assert self._mcap is not None
        self._mcap.flush()
        self._commit()

    def _commit(self) -> None:
        """The chunk in progress reached the OS: its messages count as written."""
        if not self._pending:
            return
        with self._lock:
            w = self._stats.written
            for t, n in self._pending.items():
                w[t] = w.get(t, 0) + n
            self._stats.flushes += 1
        self._pending.clear()

    def _channel(self, topic_name: str, schema: str, metadata: dict[str, str] | None = None
                 ) -> int:
        cid = self._channels.get(topic_name)
        if cid is None:
            assert self._mcap is not None
            sid = self._schemas.get(schema)
            if sid is None:
                sid = self._mcap.register_schema(schema, SchemaEncoding.ROS2,
                                                 S.SCHEMAS[schema].encode())
                self._schemas[schema] = sid
            meta = {"offered_qos_profiles": S.OFFERED_QOS}
            meta.update(metadata or {})
            cid = self._mcap.register_channel(topic_name, MessageEncoding.CDR, sid, meta)
            self._channels[topic_name] = cid
        return cid

    def _emit(self, name: str, kind: str, ns: int, data: bytes,
              metadata: dict[str, str] | None = None) -> None:
        assert self._mcap is not None
        topic_name = S.topic(name, kind)
        cid = self._channel(topic_name, S.TOPIC_KINDS[kind], metadata)
        seq = self._channel_seq[topic_name]
        self._channel_seq[topic_name] = seq + 1
        assert self._sink is not None
        before = self._sink.pos
        self._pending[topic_name] += 1
        self._mcap.add_message(cid, log_time=ns, data=data, publish_time=ns,
                               sequence=seq & 0xFFFFFFFF)
        if self._sink.pos != before:  # the chunk filled up (flush_bytes) and was written
            self._commit()

    def _handle(self, item: tuple) -> None:
        kind = item[0]
        if kind == "flush":
            self._flush()
            item[1].set()
            return
        try:
            encoded = self._encode(item)
        except (ValueError, TypeError, OverflowError, struct_error) as e:
            with self._lock:
                self._stats.encode_errors += 1
            self._tell_once(f"encode-{kind}-{item[1]}", "%s %s: cannot encode (%s); skipped",
                            item[1], kind, e)
            return
        for name, topic_kind, ns, data, meta in encoded:
            self._emit(name, topic_kind, ns, data, meta)

    def _encode(self, item: tuple) -> list[tuple[str, str, int, bytes, dict | None]]:
        tb = self.timebase
        kind, name = item[0], item[1]
        if kind == "raw":
            f: Frame = item[2]
            raw = frame_message(name, f, tb)
            ns = raw.stamp_ns
            out = [(name, "raw", ns, S.encode_raw(raw), None)]
            model = self._devices[name].force_model if name in self._devices else None
            if model is not None:
                try:
                    force = xyz(model(f.counts))
                except Exception as e:  # a model failing on one frame must not stop recording
                    with self._lock:
                        self._stats.encode_errors += 1
                    self._tell_once(f"model-{name}", "%s: force model failed (%s)", name, e)
                else:
                    out.append((name, "wrench", ns, S.encode_wrench(
                        S.WrenchMsg(ns, name, force)), None))
            return out
        if kind == "wrench":
            ns = tb.to_ns(item[2])
            return [(name, "wrench", ns, S.encode_wrench(S.WrenchMsg(ns, name, item[3],
                                                                     item[4])), None)]
        if kind == "audio":
            (_, _, host_time, first_index, frames, channels, rate, host_rate, lost, enc,
             data) = item
            ns = tb.to_ns(host_time)
            stream = self._audio.get(name)
            msg = S.AudioMsg(ns, name, first_index, frames, channels, float(rate),
                             float(host_rate), lost, enc, data)
            with self._lock:
                af = self._stats.audio_frames
                af[name] = af.get(name, 0) + frames
            return [(name, "audio", ns, S.encode_audio(msg),
                     stream.metadata if stream else None)]
        if kind == "event":
            ns = tb.to_ns(item[2])
            return [(name, "events", ns, S.encode_event(S.EventMsg(ns, name, item[3],
                                                                   item[4], item[5])), None)]
        if kind == "encoded":
            stream = self._audio.get(name) if item[2] == "audio" else None
            return [(name, item[2], item[3], item[4], stream.metadata if stream else None)]
        if kind == "info":
            ns = tb.to_ns(item[2])
            return [(name, "info", ns, S.encode_string(item[3]), None)]
        raise ValueError(f"unknown item {kind!r}")

    def _finish(self) -> None:
        assert self._mcap is not None and self._sink is not None
        self._flush()
        st = self.stats
        self._mcap.add_metadata(SUMMARY_METADATA_NAME, {
            "stop_unix_ns": str(self.timebase.to_ns(self.stop_monotonic or time.monotonic())),
            "written": json.dumps(st.written), "dropped": json.dumps(st.dropped),
            "encode_errors": str(st.encode_errors),
            "devices": json.dumps({n: asdict(d.fingertip.stats)
                                   for n, d in self._devices.items()
                                   if is_dataclass(getattr(d.fingertip, "stats", None))}),
        })
        self._mcap.finish()
        self._commit()
        self._sink.flush()
        self._close_sink()


def device_info(fingertip: Any, name: str) -> dict[str, Any]:
    """What ``/fingertip/<name>/info`` says about a fingertip (or any frame source)."""
    info: dict[str, Any] = {"name": name, "port": getattr(fingertip, "port", ""),
                            "serial_number": getattr(fingertip, "serial_number", None)}
    try:
        info["info"] = message_to_dict(fingertip.info)
    except Exception:  # not open yet (or a source without INFO): nothing to say
        pass
    settings = getattr(fingertip, "settings", None)
    if settings is not None:
        info["settings"] = asdict(settings)
    return info


def frame_message(name: str, f: Frame, tb: TimeBase) -> S.RawMsg:
    """A frame as recordings (and the network publishers) carry it: stamped with its
    clock-fitted host time (its arrival time when the fit has none yet)."""
    t = f.host_time if math.isfinite(f.host_time) else f.arrival_time
    return S.RawMsg(tb.to_ns(t), name, f.seq & 0xFFFFFFFF, f.device_time_us,
                    tb.to_ns(f.arrival_time), tuple(f.counts), f.timeout_mask,
                    f.saturation_mask)


def audio_payload(samples: Any) -> tuple[str, bytes] | None:
    """Audio samples -> ``(encoding, interleaved little-endian bytes)``, or None when their
    dtype cannot be carried (not int16, int32 or float32)."""
    a = np.asarray(samples)
    # Looked up by (kind, size): dtype.name is a Python-level property, slow per chunk.
    enc_le = _AUDIO_LE.get((a.dtype.kind, a.dtype.itemsize))
    if enc_le is None:
        return None
    enc, le = enc_le
    return enc, np.ascontiguousarray(a, dtype=le).tobytes()


_AUDIO_LE = {(np.dtype(n).kind, np.dtype(n).itemsize): (enc, np.dtype(n).newbyteorder("<"))
             for n, enc in S.AUDIO_ENCODINGS.items()}


def xyz(v: Sequence[float]) -> tuple[float, float, float]:
    vals = [float(x) for x in v]
    if not 2 <= len(vals) <= 3:
        raise ValueError(f"expected (x, y) or (x, y, z), got {len(vals)} values")
    if len(vals) == 2:
        vals.append(0.0)
    return vals[0], vals[1], vals[2]

