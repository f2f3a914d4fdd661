"""The MCAP writer's chunk index, kept packed: memory that grows by about 240 bytes a chunk
instead of about 1.4 kB.

An indexed MCAP file ends with one ChunkIndex record per chunk, so the writer must keep them
all until it closes the file. ``mcap.writer.Writer`` keeps each as a dataclass holding a
dict of message-index offsets (one per channel in the chunk): with 16 channels and a chunk
every 0.5 s (the recorder's crash-safety flush) that is about 10 MB an hour, which a long
recording pays in memory for nothing. :class:`PackedChunkIndexes` keeps the bytes the
summary will hold instead, and writes them unchanged at the end: the file is byte for byte
the one the plain writer makes (tested).

The writer reaches its list through one private attribute of the pinned ``mcap`` release
(it only appends to it and iterates over it when it finishes the file);
:func:`pack_chunk_indexes` checks that it is there and leaves the writer as it is if not.
"""
from __future__ import annotations

import logging
from collections.abc import Iterator

from mcap.data_stream import RecordBuilder
from mcap.records import ChunkIndex
from mcap.writer import Writer

log = logging.getLogger(__name__)

_ATTRIBUTE = "_Writer__chunk_indices"


class _Packed:
    """What the writer's summary loop needs of a chunk index: ``write(builder)``."""

    __slots__ = ("data",)

    def __init__(self, data: bytes) -> None:
        self.data = data

    def write(self, stream: RecordBuilder) -> None:
        stream.write(self.data)


class PackedChunkIndexes:
    """An append-only list of ChunkIndex records serialised as they arrive."""

    def __init__(self) -> None:
        self._data = bytearray()
        self._count = 0
        self._builder = RecordBuilder()

    def append(self, index: ChunkIndex) -> None:
        index.write(self._builder)
        self._data += self._builder.end()
        self._count += 1

    def __len__(self) -> int:
        return self._count

    def __iter__(self) -> Iterator[_Packed]:
        # The records are written back to back, so one write of all of them is the same
        # bytes as one write each.
        if self._count:
            yield _Packed(bytes(self._data))

    @property
    def nbytes(self) -> int:
        """Bytes the packed records take."""
        return len(self._data)


def pack_chunk_indexes(writer: Writer) -> bool:
    """Make ``writer`` (before its first chunk) keep its chunk index packed. False, and the
    writer unchanged, when this ``mcap`` release keeps it differently."""
    current = getattr(writer, _ATTRIBUTE, None)
    if not isinstance(current, list) or current:
        log.debug("mcap's Writer keeps no empty chunk-index list; left as it is")
        return False
    setattr(writer, _ATTRIBUTE, PackedChunkIndexes())
    return True
