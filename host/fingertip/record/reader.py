"""Reading recordings, including ones cut short by a crash.

:class:`Recording` reads an MCAP file sequentially with the ``mcap`` package's
:class:`~mcap.stream_reader.StreamReader` (CRCs checked). A complete file ends with its
summary and footer; a file whose writer was killed ends somewhere inside a record. Such a
file is read up to the end of its last complete chunk: the incomplete trailing record is
skipped (``Recording.truncated`` tells, ``Recording.problem`` says where). This is our own
recovery read, not a mode of the ``mcap`` package (whose indexed reader needs the footer);
the ``mcap`` CLI's ``mcap recover`` does the same and also rewrites a complete file.

Messages come in file order from :meth:`Recording.records`, or close to log-time order
from :meth:`Recording.messages` (a small reordering window: audio chunks are stamped with
the time of their first sample, which is earlier than the moment they were written).
"""
from __future__ import annotations

import heapq
import io
import itertools
import json
import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcap.exceptions import EndOfFile
from mcap.reader import SeekingReader
from mcap.records import Channel, Footer, Header, Message, Metadata, Schema
from mcap.stream_reader import CRCValidationError, StreamReader

from ..badfile import special_kind, stat_or_none
from ..errors import Error
from . import schemas as S
from .writer import METADATA_NAME, SUMMARY_METADATA_NAME
from .timebase import TimeBase

MAGIC = b"\x89MCAP0\r\n"


class RecordingError(Error, RuntimeError):
    """The file is missing, unreadable, or not a fingertip MCAP recording (the user's
    input: exit status 2)."""

    exit_code = 2


@dataclass(frozen=True, slots=True)
class Record:
    """One decoded message: which fingertip, which topic kind, its log time and content."""

    name: str
    kind: str
    """raw, wrench, audio, events or info."""
    log_time: int
    """Unix-epoch nanoseconds (equal to the header stamp)."""
    msg: Any
    """:class:`~.schemas.RawMsg`, ``WrenchMsg``, ``AudioMsg``, ``EventMsg``, or a str (info)."""
    topic: str = ""


@dataclass
class ChannelInfo:
    topic: str
    name: str
    kind: str
    schema: str
    metadata: dict[str, str] = field(default_factory=dict)
    messages: int | None = None
    """From the summary (complete files); None when unknown."""


class Recording:
    """A fingertip recording on disk. Cheap to create; every read opens the file anew."""

    def __init__(self, path: str | os.PathLike) -> None:
        self.path = Path(path)
        if not self.path.exists():
            raise RecordingError(f"{self.path}: no such file")
        if self.path.is_dir():
            raise RecordingError(f"{self.path}: is a directory, not an MCAP recording")
        if (st := stat_or_none(self.path)) is not None and special_kind(st.st_mode):
            raise RecordingError(f"{self.path}: is {special_kind(st.st_mode)}, not an MCAP "
                                 "recording")  # open() on a FIFO would wait for ever
        try:
            with open(self.path, "rb") as f:
                head = f.read(len(MAGIC))
        except OSError as e:
            raise RecordingError(f"{self.path}: cannot read ({e.strerror or e})") from e
        if head != MAGIC:
            raise RecordingError(f"{self.path}: not an MCAP file (bad magic)")
        self.truncated = False
        """The file ended inside a record (a killed writer): read up to the last whole one."""
        self.problem = ""
        self.metadata: dict[str, dict[str, str]] = {}
        self._channels: dict[str, ChannelInfo] | None = None
        self._read_metadata_head()
        meta = self.metadata.get(METADATA_NAME, {})
        try:
            self.timebase = TimeBase(int(meta["monotonic_to_unix_ns"]))
        except (KeyError, ValueError):
            # Not written by our recorder: stamps are taken as Unix time, monotonic = 0-based.
            self.timebase = TimeBase(0)
        self.start_unix_ns = int(meta.get("start_unix_ns", "0") or 0)

    # --- low level ------------------------------------------------------------------------

    def _read_metadata_head(self) -> None:
        """The metadata records at the start of the file (before the first chunk)."""
        with open(self.path, "rb") as f:
            reader = StreamReader(f, emit_chunks=True)
            try:
                for rec in reader.records:
                    if isinstance(rec, Metadata):
                        self.metadata[rec.name] = dict(rec.metadata)
                    elif not isinstance(rec, Header):
                        break
            except Exception:  # a truncated or damaged head: what was read is kept
                pass

    def records(self, kinds: Iterable[str] | None = None,
                names: Iterable[str] | None = None) -> Iterator[Record]:
        """Decoded messages in file order, up to the last complete chunk."""
        kinds = set(kinds) if kinds is not None else None
        names = set(names) if names is not None else None
        channels: dict[int, tuple[str, str, Any] | None] = {}
        schemas: dict[int, Schema] = {}
        with open(self.path, "rb") as f:
            reader = StreamReader(io.BufferedReader(f, 1 << 20), validate_crcs=True)
            it = reader.records
            while True:
                try:
                    rec = next(it)
                except StopIteration:
                    return
                except EndOfFile:
                    self.truncated = True
                    self.problem = ("the file ends inside a record (recording interrupted; "
                                    "`fingertip repair` makes a complete copy)")
                    return
                except Exception as e:  # damaged bytes: CRC, zstd, struct, decode errors
                    self.truncated = True
                    kind = "bad CRC" if isinstance(e, CRCValidationError) else \
                        type(e).__name__
                    self.problem = (f"damaged data after the last good chunk ({kind}: {e}); "
                                    f"`fingertip repair` keeps the good chunks after it too")
                    return
                if isinstance(rec, Message):
                    ch = channels.get(rec.channel_id)
                    if ch is None:
                        continue
                    name, kind, decode = ch
                    if (kinds is not None and kind not in kinds) or \
                            (names is not None and name not in names):
                        continue
                    try:
                        msg = decode(rec.data)
                    except (ValueError, UnicodeDecodeError, IndexError) as e:
                        self.problem = f"undecodable message on {kind} of {name}: {e}"
                        continue
                    yield Record(name, kind, rec.log_time, msg, S.topic(name, kind))
                elif isinstance(rec, Schema):
                    schemas[rec.id] = rec
                elif isinstance(rec, Channel):
                    channels[rec.id] = self._decoder_for(rec, schemas.get(rec.schema_id))
                elif isinstance(rec, Metadata):
                    self.metadata[rec.name] = dict(rec.metadata)
                elif isinstance(rec, Footer):
                    return

    @staticmethod
    def _decoder_for(ch: Channel, schema: Schema | None):
        parts = S.split_topic(ch.topic)
        if parts is None or schema is None or ch.message_encoding != "cdr":
            return None
        name, kind = parts
        if schema.name != S.TOPIC_KINDS[kind]:
            return None
        return name, kind, S.DECODERS[schema.name]

    def messages(self, kinds: Iterable[str] | None = None, names: Iterable[str] | None = None,
                 window: float = 2.0) -> Iterator[Record]:
        """Decoded messages in log-time order, given that no message was written more than
        ``window`` seconds after a message stamped later than it (true of our recorder,
        whose audio chunks are at most a few hundred milliseconds late)."""
        w = int(window * S.NS)
        heap: list[tuple[int, int, Record]] = []
        counter = itertools.count()
        newest = None
        for r in self.records(kinds, names):
            heapq.heappush(heap, (r.log_time, next(counter), r))
            newest = r.log_time if newest is None else max(newest, r.log_time)
            while heap and heap[0][0] < newest - w:
                yield heapq.heappop(heap)[2]
        while heap:
            yield heapq.heappop(heap)[2]

    # --- what is in it --------------------------------------------------------------------

    def channels(self) -> dict[str, ChannelInfo]:
        """Our topics in the file. From the summary of a complete file; a truncated one is
        read through once."""
        if self._channels is not None:
            return self._channels
        out: dict[str, ChannelInfo] = {}
        summary = None
        try:
            with open(self.path, "rb") as f:
                summary = SeekingReader(f).get_summary()
        except Exception:  # no footer or summary (truncated): read the channels instead
            summary = None
        if summary is not None and summary.channels:
            counts = summary.statistics.channel_message_counts if summary.statistics else {}
            for cid, ch in summary.channels.items():
                sc = summary.schemas.get(ch.schema_id)
                if self._decoder_for(ch, sc) is None:
                    continue
                name, kind = S.split_topic(ch.topic)  # type: ignore[misc]
                out[ch.topic] = ChannelInfo(ch.topic, name, kind, sc.name if sc else "",
                                            dict(ch.metadata), counts.get(cid))
        else:
            schemas: dict[int, Schema] = {}
            with open(self.path, "rb") as f:
                reader = StreamReader(io.BufferedReader(f, 1 << 20))
                try:
                    for rec in reader.records:
                        if isinstance(rec, Schema):
                            schemas[rec.id] = rec
                        elif isinstance(rec, Channel):
                            sc = schemas.get(rec.schema_id)
                            if self._decoder_for(rec, sc) is not None:
                                name, kind = S.split_topic(rec.topic)  # type: ignore[misc]
                                out[rec.topic] = ChannelInfo(rec.topic, name, kind,
                                                             sc.name if sc else "",
                                                             dict(rec.metadata))
                except Exception:  # EndOfFile (truncated) or damaged data: keep what we have
                    self.truncated = True
        self._channels = out
        return out

    @property
    def complete(self) -> bool:
        """The file has its footer (the recorder finished it)."""
        try:
            with open(self.path, "rb") as f:
                f.seek(-len(MAGIC), os.SEEK_END)
                return f.read() == MAGIC and os.path.getsize(self.path) > 2 * len(MAGIC)
        except OSError:
            return False

    def link_counters(self) -> dict[str, dict[str, int]]:
        """Each recorded fingertip's link counters when the recording ended (``frames_lost``,
        ``outage_frames``, ``device_resets``, ``reconnects``...: docs/protocol.md), from the
        summary the recorder writes last; empty for a file cut short or without them."""
        if not self.complete:
            return {}
        try:
            with open(self.path, "rb") as f:
                for m in SeekingReader(f).iter_metadata():
                    if m.name == SUMMARY_METADATA_NAME:
                        return json.loads(m.metadata.get("devices", "{}"))
        except Exception:  # no summary section, or a damaged one: nothing to report
            return {}
        return {}

    def names(self) -> list[str]:
        """Fingertip names that have any topic in the file."""
        return sorted({c.name for c in self.channels().values()})

    def devices(self) -> list[str]:
        """Fingertip names with raw frames."""
        return sorted({c.name for c in self.channels().values() if c.kind == "raw"})

    def audio_streams(self) -> list[str]:
        return sorted({c.name for c in self.channels().values() if c.kind == "audio"})

    def has(self, name: str, kind: str) -> bool:
        return S.topic(name, kind) in self.channels()

    def info(self, name: str) -> dict[str, Any] | None:
        """The JSON the recorder stored on ``/fingertip/<name>/info`` (the first one)."""
        for r in self.records(kinds=("info",), names=(name,)):
            try:
                return json.loads(r.msg)
            except ValueError:
                return {"text": r.msg}
        return None
