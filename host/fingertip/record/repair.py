"""``repair``: a complete, indexed copy of an MCAP file whose writer was killed or whose
bytes were damaged.

A killed recorder leaves a file without its summary and footer, often ending inside a
chunk. Our own reader copes, but the ``mcap`` package's ordinary reader
(``make_reader(f).iter_messages()``, what other tools use first) seeks to the footer and
fails. :func:`repair` walks the file record by record (opcode, length, body), keeps every
record that parses and passes its CRC, skips a damaged chunk whose length is intact and
goes on after it, stops at a record cut short or unreadable, and writes everything kept
through the ``mcap`` package's writer, which adds the chunk indexes, summary and footer.
It reports what was kept and what was lost.
"""
from __future__ import annotations

import io
import os
import struct
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from mcap.exceptions import EndOfFile
from mcap.records import Attachment, Channel, Header, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter

from ..badfile import BadFileError, require_file
from ..outputs import atomic_output, check_output
from .packed_index import pack_chunk_indexes

MAGIC = b"\x89MCAP0\r\n"
OP_FOOTER, OP_CHUNK = 0x02, 0x06
KNOWN_OPCODES = range(0x01, 0x10)
"""MCAP's record opcodes; anything else means the walk lost its footing in damaged bytes."""
COMPRESSIONS = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4,
                "": CompressionType.NONE}
NS = 1_000_000_000


@dataclass
class RepairResult:
    """What :func:`repair` kept and lost."""

    source: Path
    output: Path
    was_complete: bool
    """The source already ended with its footer (the copy is then only re-indexed)."""
    messages: Counter = field(default_factory=Counter)
    """Messages kept, by topic."""
    chunks_kept: int = 0
    damaged_records: list[tuple[int, str]] = field(default_factory=list)
    """(offset, why) of records skipped: bad CRC, undecodable chunk..."""
    orphan_messages: int = 0
    """Messages on a channel whose definition was lost with a damaged record."""
    tail_offset: int | None = None
    """Where the walk stopped before the end of the file (None: it read to the end)."""
    tail_bytes: int = 0
    """Bytes from there to the end of the file, lost."""
    tail_reason: str = ""
    lost_span_ns: tuple[int, int] | None = None
    """Log-time span of the messages of the chunk cut short, when its header survived."""
    last_log_time: int | None = None

    @property
    def kept(self) -> int:
        return sum(self.messages.values())

    @property
    def lost_anything(self) -> bool:
        return bool(self.tail_bytes or self.damaged_records or self.orphan_messages)

    def summary(self) -> str:
        """One line saying what was kept and lost."""
        topics = ", ".join(f"{t} {n}" for t, n in sorted(self.messages.items()))
        parts = [f"kept {self.kept} messages ({topics or 'none'}) in {self.chunks_kept} "
                 f"chunks"]
        if self.was_complete and not self.lost_anything:
            parts.append("the file was complete: nothing lost")
        elif not self.was_complete and not self.tail_bytes:
            parts.append("the file ended after a whole record, without its footer: nothing "
                         "in it was lost (what its writer had not yet written never reached "
                         "the file)")
        if self.tail_bytes:
            span = ""
            if self.lost_span_ns is not None:
                a, b = self.lost_span_ns
                span = (f", holding messages from {a / NS:.3f} to {b / NS:.3f} s "
                        f"(Unix time)")
            parts.append(f"lost the last {self.tail_bytes} bytes from offset "
                         f"{self.tail_offset} ({self.tail_reason}{span})")
        if self.damaged_records:
            parts.append(f"skipped {len(self.damaged_records)} damaged record(s) at offset(s) "
                         + ", ".join(str(o) for o, _ in self.damaged_records[:5]))
        if self.orphan_messages:
            parts.append(f"{self.orphan_messages} messages lost with their channel")
        return "; ".join(parts)

    def as_dict(self) -> dict:
        return {"source": str(self.source), "output": str(self.output),
                "was_complete": self.was_complete, "messages": dict(self.messages),
                "kept": self.kept, "chunks_kept": self.chunks_kept,
                "damaged_records": [{"offset": o, "why": w} for o, w in self.damaged_records],
                "orphan_messages": self.orphan_messages, "tail_offset": self.tail_offset,
                "tail_bytes": self.tail_bytes, "tail_reason": self.tail_reason,
                "lost_span_ns": list(self.lost_span_ns) if self.lost_span_ns else None,
                "last_log_time": self.last_log_time}


def default_output(path: str | os.PathLike) -> Path:
    """``run.mcap`` -> ``run.repaired.mcap`` beside it."""
    p = Path(path)
    return p.with_name(f"{p.stem}.repaired{p.suffix or '.mcap'}")


def _walk(f, size: int, result: RepairResult) -> Iterator[tuple[int, int, bytes]]:
    """(offset, opcode, whole record bytes) of each record that is there in full."""
    pos = len(MAGIC)
    while pos < size:
        head = f.read(9)
        if len(head) < 9:
            _stop(result, pos, size, "the file ends inside a record header")
            return
        opcode, length = struct.unpack("<BQ", head)
        if opcode not in KNOWN_OPCODES:
            _stop(result, pos, size, f"unreadable bytes (opcode 0x{opcode:02X})")
            return
        if pos + 9 + length > size:
            _stop(result, pos, size, "the file ends inside a "
                  + ("chunk" if opcode == OP_CHUNK else f"record (opcode 0x{opcode:02X})"))
            if opcode == OP_CHUNK:
                start_end = f.read(16)
                if len(start_end) == 16:
                    result.lost_span_ns = struct.unpack("<QQ", start_end)
            return
        body = f.read(length)
        yield pos, opcode, head + body
        pos += 9 + length
        if opcode == OP_FOOTER:
            return


def _stop(result: RepairResult, pos: int, size: int, why: str) -> None:
    result.tail_offset, result.tail_bytes, result.tail_reason = pos, size - pos, why


def _parse(record: bytes) -> list:
    """The records inside one record's bytes (a chunk's messages...), CRCs checked."""
    out = []
    reader = StreamReader(io.BytesIO(record), skip_magic=True, validate_crcs=True)
    try:
        for r in reader.records:
            out.append(r)
    except EndOfFile:
        pass  # the end of this one record's bytes
    return out


def _first_compression(f, size: int) -> str:
    """The compression of the file's first chunk ("zstd", "lz4" or "" for none), found by
    hopping over record headers; "zstd" when no chunk header is readable."""
    pos = len(MAGIC)
    while pos + 9 <= size:
        f.seek(pos)
        opcode, length = struct.unpack("<BQ", f.read(9))
        if opcode not in KNOWN_OPCODES:
            break
        if opcode == OP_CHUNK:
            f.seek(pos + 9 + 28)
            raw = f.read(4)
            if len(raw) < 4:
                break
            (n,) = struct.unpack("<I", raw)
            name = f.read(min(n, 16)).decode("ascii", "replace")
            return name if name in COMPRESSIONS else "zstd"
        pos += 9 + length
    return "zstd"


def repair(path: str | os.PathLike, output: str | os.PathLike | None = None, *,
           overwrite: bool = False, chunk_size: int = 1 << 20) -> RepairResult:
    """Write a complete, indexed copy of the MCAP file ``path`` to ``output`` (default
    :func:`default_output`). Raises :class:`~fingertip.badfile.BadFileError` when ``path``
    is not an MCAP file, :class:`~fingertip.outputs.OutputExists` (a FileExistsError) when
    ``output`` exists and not ``overwrite``, :class:`~fingertip.errors.OutputRefused` when it
    is a folder, a FIFO or a device, BadFileError when it is the input."""
    src = require_file(path, "MCAP recording")
    out = Path(output) if output is not None else default_output(src)
    if out.resolve() == src.resolve():
        raise BadFileError(f"{out}: the copy must not replace the file being repaired", out)
    check_output(out, force=overwrite, inputs=[src], what="repaired copy")
    size = src.stat().st_size
    with open(src, "rb") as f:
        if f.read(len(MAGIC)) != MAGIC:
            raise BadFileError(f"{src}: not an MCAP file (bad magic)", src)
        f.seek(-len(MAGIC), os.SEEK_END)
        complete = size > 2 * len(MAGIC) and f.read() == MAGIC
        f.seek(len(MAGIC))
        result = RepairResult(src, out, complete)
        compression = COMPRESSIONS[_first_compression(f, size)]
        f.seek(0)
        spare = _summary_definitions(f) if complete else {}
        f.seek(len(MAGIC))
        # A unique temporary file (never a name derived from the output's: the input may
        # be called just that), renamed over the output only if that is a regular file.
        with atomic_output(out) as tmp:
            _copy(f, size, tmp, result, chunk_size, compression, spare)
    return result


def _summary_definitions(f) -> dict:
    """Schemas and channels from the summary of a file that has one: they stand in for
    definitions lost in a damaged chunk."""
    from mcap.reader import SeekingReader

    try:
        summary = SeekingReader(f, validate_crcs=True).get_summary()
    except Exception:  # a damaged summary: nothing to fall back on
        return {}
    if summary is None:
        return {}
    return {"schemas": dict(summary.schemas), "channels": dict(summary.channels)}


def _copy(f, size: int, tmp: Path, result: RepairResult, chunk_size: int,
          compression: CompressionType, spare: dict) -> None:
    schemas: dict[int, int] = {}
    channels: dict[int, tuple[int, str]] = {}
    with open(tmp, "wb") as sink:
        writer = McapWriter(sink, chunk_size=chunk_size, compression=compression)
        pack_chunk_indexes(writer)
        started = False
        for pos, opcode, record in _walk(f, size, result):
            try:
                items = _parse(record)
            except Exception as e:  # CRC, decompression, struct: this record is lost
                result.damaged_records.append((pos, f"{type(e).__name__}: {e}"[:200]))
                continue
            if not started:
                header = next((r for r in items if isinstance(r, Header)), None)
                writer.start(profile=header.profile if header else "",
                             library=header.library if header else "fingertip repair")
                started = True
            if opcode == OP_CHUNK:
                result.chunks_kept += 1
            for r in items:
                if isinstance(r, Message) and r.channel_id not in channels:
                    _define(writer, r.channel_id, spare, schemas, channels, result)
                _write(writer, r, schemas, channels, result)
        if not started:  # nothing usable after the magic: still a valid (empty) file
            writer.start(profile="", library="fingertip repair")
        writer.finish()


def _define(writer: McapWriter, channel_id: int, spare: dict, schemas: dict[int, int],
            channels: dict[int, tuple[int, str]], result: RepairResult) -> None:
    """Register a channel (and its schema) known only from the summary."""
    ch = spare.get("channels", {}).get(channel_id)
    if ch is None:
        return
    sc = spare.get("schemas", {}).get(ch.schema_id)
    if sc is not None:
        _write(writer, sc, schemas, channels, result)
    _write(writer, ch, schemas, channels, result)


def _write(writer: McapWriter, r, schemas: dict[int, int],
           channels: dict[int, tuple[int, str]], result: RepairResult) -> None:
    if isinstance(r, Message):
        ch = channels.get(r.channel_id)
        if ch is None:
            result.orphan_messages += 1
            return
        writer.add_message(ch[0], r.log_time, r.data, r.publish_time, r.sequence)
        result.messages[ch[1]] += 1
        if result.last_log_time is None or r.log_time > result.last_log_time:
            result.last_log_time = r.log_time
    elif isinstance(r, Schema):
        if r.id not in schemas:
            schemas[r.id] = writer.register_schema(r.name, r.encoding, r.data)
    elif isinstance(r, Channel):
        if r.id not in channels:
            sid = 0 if r.schema_id == 0 else schemas.get(r.schema_id)
            if sid is None:  # its schema was lost: its messages cannot be decoded
                return
            channels[r.id] = (writer.register_channel(r.topic, r.message_encoding, sid,
                                                      dict(r.metadata)), r.topic)
    elif isinstance(r, Metadata):
        writer.add_metadata(r.name, dict(r.metadata))
    elif isinstance(r, Attachment):
        writer.add_attachment(r.create_time, r.log_time, r.name, r.media_type, r.data)
