"""The recorder's queue and the one thread that encodes what is queued and writes it to the
MCAP file in chunks.

Producers (any thread) :meth:`RecordWriter.put` items, which never blocks: a full queue or
a failed writer counts the item as dropped. The thread encodes each item
(:func:`~fingertip.record.encoding.encode_item`) and adds it to the chunk in progress; every
``flush_interval`` seconds, or when a chunk reaches ``flush_bytes``, the chunk is written to
the OS (a killed process leaves the file readable up to there) and its messages count as
written. A write error keeps the first :class:`RecorderError`, counts what is lost and
closes the file; nothing hangs.
"""
from __future__ import annotations

import json
import logging
import queue
import threading
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from struct import error as struct_error
from typing import Any

from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter

from .. import __version__
from ..errors import EXIT_FAILED
from . import schemas as S
from .encoding import ForceModel, encode_item, item_topic
from .packed_index import pack_chunk_indexes
from .sink import Sink, io_error, open_output
from .stats import RecorderError, RecorderStats
from .timebase import TimeBase

log = logging.getLogger(__name__)

METADATA_NAME = "fingertip"
SUMMARY_METADATA_NAME = "fingertip.summary"
COMPRESSIONS = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4,
                "none": CompressionType.NONE}


class RecordWriter:
    """Queue and writer thread of one recording to ``path``. ``force_model_of(name)`` and
    ``audio_metadata_of(name)`` look up what the recorder knows of a fingertip when its
    items are encoded."""

    def __init__(self, path: Path, *, queue_size: int, flush_interval: float,
                 flush_bytes: int, compression: str, fsync: bool, overwrite: bool,
                 timebase: TimeBase, force_model_of: Callable[[str], ForceModel | None],
                 audio_metadata_of: Callable[[str], dict[str, str] | None],
                 link_counters: Callable[[], dict[str, dict[str, int]]] = dict) -> None:
        self.path = path
        self.flush_interval = flush_interval
        self.flush_bytes = flush_bytes
        self.compression = compression
        self.fsync = fsync
        self.overwrite = overwrite
        self.timebase = timebase
        self._force_model_of = force_model_of
        self._audio_metadata_of = audio_metadata_of
        self._link_counters = link_counters
        self._queue: queue.Queue = queue.Queue(maxsize=queue_size)
        self._lock = threading.Lock()
        self._stats = RecorderStats()
        self._sink: Sink | None = None
        self._mcap: McapWriter | None = None
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._channel_seq: Counter[str] = Counter()
        self._pending: Counter[str] = Counter()
        self._thread: threading.Thread | None = None
        self._closing = threading.Event()
        self._accepting = False
        self._created = False
        self._told: set[str] = set()
        self.error: RecorderError | None = None
        """Why writing failed, or None."""
        self.stop_monotonic: float | None = None

    # --- the file -------------------------------------------------------------------------

    def create(self) -> None:
        """Create the file (a :class:`RecorderError` says why it cannot be)."""
        fd, self._created = open_output(self.path, self.overwrite)
        self._sink = Sink(fd, self.fsync)

    def begin(self, metadata: dict[str, str]) -> None:
        """Write the MCAP header and ``metadata``; from now on, items are accepted. On a
        write error the file is closed (and removed if this recording created it)."""
        assert self._sink is not None
        try:
            self._mcap = McapWriter(self._sink, chunk_size=self.flush_bytes,
                                    compression=COMPRESSIONS[self.compression])
            pack_chunk_indexes(self._mcap)  # memory for the index: ~240 B a chunk, not 1.4 kB
            self._mcap.start(profile="ros2",
                             library=f"fingertip/{__version__} (mcap-python, ROS 2 CDR)")
            self._mcap.add_metadata(METADATA_NAME, metadata)
            self._sink.flush()
        except OSError as e:
            self._close_sink()
            if self._created:  # do not leave an empty, unreadable file behind
                try:
                    self.path.unlink()
                except OSError:
                    pass
            raise io_error(self.path, e, "cannot write") from e
        self._accepting = True

    def start(self) -> None:
        """Start the writer thread."""
        self._thread = threading.Thread(target=self._run, daemon=True,
                                        name=f"recorder-{self.path.name}")
        self._thread.start()

    def close(self, deadline: float, timeout: float, stop_monotonic: float) -> None:
        """Write what is queued and finish the file by ``deadline`` (monotonic seconds);
        a writer stuck in the OS is abandoned and reported in :attr:`error`."""
        self.stop_monotonic = stop_monotonic
        self._closing.set()
        thread = self._thread
        if thread is not None:
            thread.join(timeout=max(0.0, deadline - time.monotonic()))
            if thread.is_alive():
                self._fail(RecorderError(f"writing {self.path} did not finish within "
                                         f"{timeout:.0f} s (is the disk stuck?)"))

    # --- counters -------------------------------------------------------------------------

    @property
    def stats(self) -> RecorderStats:
        with self._lock:
            s = self._stats
            return RecorderStats(dict(s.accepted), dict(s.written), dict(s.dropped),
                                 self._sink.pos if self._sink else 0, s.flushes,
                                 s.queue_high_water, s.encode_errors, dict(s.audio_frames))

    def count_drop(self, topic_name: str) -> None:
        with self._lock:
            d = self._stats.dropped
            d[topic_name] = d.get(topic_name, 0) + 1

    def tell_once(self, key: str, msg: str, *args: Any) -> None:
        """Log a warning the first time ``key`` comes up (a bad value repeats every frame)."""
        if key not in self._told:
            self._told.add(key)
            log.warning(msg, *args)

    # --- the queue (any thread, never blocks) ---------------------------------------------

    def put(self, topic_name: str, item: tuple) -> bool:
        """Queue ``item`` for ``topic_name``; False (and counted as dropped) when the queue
        is full or nothing is accepted (not begun, failed, closing)."""
        if not self._accepting or self.error is not None or self._closing.is_set():
            self.count_drop(topic_name)
            return False
        try:
            self._queue.put_nowait(item)
        except queue.Full:
            self.count_drop(topic_name)
            return False
        n = self._queue.qsize()
        with self._lock:
            a = self._stats.accepted
            a[topic_name] = a.get(topic_name, 0) + 1
            if n > self._stats.queue_high_water:
                self._stats.queue_high_water = n
        return True

    # --- the writer thread ----------------------------------------------------------------

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
            # after the start the path was accepted: whatever the OS says now is a failure
            self._fail(io_error(self.path, e, "writing failed:", code=EXIT_FAILED))
        except Exception as e:  # a bug must still leave a clear error, not a dead thread
            log.exception("recorder writer failed")
            self._fail(RecorderError(f"recording to {self.path} failed: {e}"))

    def _fail(self, err: RecorderError) -> None:
        if self.error is None:
            self.error = err
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
                self.count_drop(item_topic(item))
        self._close_sink()

    def _close_sink(self) -> None:
        sink = self._sink
        if sink is not None and getattr(sink, "fd", -1) >= 0:
            try:
                sink.close()
            except OSError:
                pass
            sink.fd = -1

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
            self.tell_once(f"encode-{kind}-{item[1]}", "%s %s: cannot encode (%s); skipped",
                           item[1], kind, e)
            return
        for name, topic_kind, ns, data, meta in encoded:
            self._emit(name, topic_kind, ns, data, meta)

    def _encode(self, item: tuple) -> list:
        kind, name = item[0], item[1]
        if kind == "audio":
            with self._lock:
                af = self._stats.audio_frames
                af[name] = af.get(name, 0) + item[4]
        audio = kind == "audio" or (kind == "encoded" and item[2] == "audio")
        return encode_item(item, self.timebase,
                           force_model=self._force_model_of(name) if kind == "raw" else None,
                           audio_metadata=self._audio_metadata_of(name) if audio else None,
                           on_model_error=self._model_failed)

    def _model_failed(self, name: str, e: Exception) -> None:
        with self._lock:
            self._stats.encode_errors += 1
        self.tell_once(f"model-{name}", "%s: force model failed (%s)", name, e)

    def _finish(self) -> None:
        assert self._mcap is not None and self._sink is not None
        self._flush()
        st = self.stats
        self._mcap.add_metadata(SUMMARY_METADATA_NAME, {
            "stop_unix_ns": str(self.timebase.to_ns(self.stop_monotonic or time.monotonic())),
            "written": json.dumps(st.written), "dropped": json.dumps(st.dropped),
            "encode_errors": str(st.encode_errors),
            "devices": json.dumps(self._link_counters()),
        })
        self._mcap.finish()
        self._commit()
        self._sink.flush()
        self._close_sink()
