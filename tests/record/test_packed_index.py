"""The packed chunk index: the same file, byte for byte, in a fraction of the memory."""
from __future__ import annotations

import io
import tracemalloc

from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from fingertip.record.packed_index import PackedChunkIndexes, pack_chunk_indexes

CHANNELS = 16


class _Discard(io.RawIOBase):
    """A sink that keeps nothing but its position (the memory test counts the index only)."""

    def __init__(self) -> None:
        self.pos = 0

    def writable(self) -> bool:
        return True

    def write(self, b) -> int:  # type: ignore[override]
        self.pos += len(b)
        return len(b)

    def tell(self) -> int:
        return self.pos


def _write(packed: bool, chunks: int, out: io.IOBase | None = None) -> tuple[bytes, Writer]:
    out = io.BytesIO() if out is None else out
    w = Writer(out, chunk_size=1 << 20, compression=CompressionType.LZ4)
    if packed:
        assert pack_chunk_indexes(w)
    w.start("ros2", "test")
    sid = w.register_schema("s", "ros2msg", b"int32 x")
    ids = [w.register_channel(f"/t{i}", "cdr", sid, {"i": str(i)}) for i in range(CHANNELS)]
    t = 0
    for _ in range(chunks):
        for cid in ids:
            for _ in range(3):
                t += 1_000
                w.add_message(cid, log_time=t, data=t.to_bytes(8, "little"), publish_time=t,
                              sequence=t)
        w.flush()  # one chunk, as the recorder's crash-safety flush makes
    w.finish()
    return out.getvalue() if isinstance(out, io.BytesIO) else b"", w


def test_file_is_byte_for_byte_the_plain_writers() -> None:
    plain, _ = _write(False, 300)
    packed, _ = _write(True, 300)
    assert packed == plain
    reader = make_reader(io.BytesIO(packed))
    summary = reader.get_summary()
    assert summary is not None and len(summary.chunk_indexes) == 300
    assert sum(1 for _ in reader.iter_messages()) == 300 * CHANNELS * 3


def test_no_chunk_writes_an_empty_index_as_the_plain_writer() -> None:
    assert _write(True, 0)[0] == _write(False, 0)[0]


def _index_memory(packed: bool, chunks: int) -> int:
    """Bytes the index holds after ``chunks`` chunks, the one thing kept per chunk."""
    tracemalloc.start()
    try:
        _, w = _write(packed, 0, _Discard())  # warm imports and caches
        before = tracemalloc.take_snapshot()
        _, w = _write(packed, chunks, _Discard())
        after = tracemalloc.take_snapshot()
        stats = after.filter_traces([tracemalloc.Filter(True, "*mcap*"),
                                     tracemalloc.Filter(True, "*packed_index*")]) \
            .compare_to(before.filter_traces([tracemalloc.Filter(True, "*mcap*"),
                                              tracemalloc.Filter(True, "*packed_index*")]),
                        "filename")
        del w
        return sum(s.size_diff for s in stats)
    finally:
        tracemalloc.stop()


def test_index_memory_per_chunk_is_a_fraction_of_the_plain_writers() -> None:
    plain = _index_memory(False, 400) / 400
    packed = _index_memory(True, 400) / 400
    # 16 channels: ~1.4 kB a chunk as dataclasses and dicts, ~240 B packed.
    assert packed < 0.3 * plain, (plain, packed)
    assert packed < 400


def test_packed_list_counts_and_writes_in_order() -> None:
    plain, w = _write(False, 5)
    packed_list = PackedChunkIndexes()
    reader = make_reader(io.BytesIO(plain))
    for index in reader.get_summary().chunk_indexes:
        packed_list.append(index)
    assert len(packed_list) == 5 and packed_list.nbytes > 5 * 100


def test_a_writer_without_the_list_is_left_as_it_is() -> None:
    class Other:
        pass

    assert not pack_chunk_indexes(Other())  # type: ignore[arg-type]
    out = io.BytesIO()
    w = Writer(out)
    w.start("", "")
    assert pack_chunk_indexes(w)
    assert not pack_chunk_indexes(w)  # already packed: not replaced twice
