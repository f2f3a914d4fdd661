"""Throughput of the Python stream decoder on four-channel sample frames.

Fed in chunks the way a serial read loop receives them: sizes spread log-uniformly between 1
and 512 bytes, so that frames straddle chunk boundaries. Fixed 64 B and 4 KiB chunks are
measured in the same run for comparison. Single thread, pinned to one core where possible.
"""
from __future__ import annotations

import math
import os
import random
import statistics
import time

from fingertip.protocol import Sample, StreamDecoder, encode

N_FRAMES = 200_000
REPEATS = 5


def _wire(rng: random.Random) -> bytes:
    return b"".join(
        encode(Sample(i & 0xFFFF, (i * 12_500) & 0xFFFFFFFF,
                      tuple(rng.randint(-(1 << 23), (1 << 23) - 1) for _ in range(4))))
        for i in range(N_FRAMES))


def _chunks(wire: bytes, sizes: list[int]) -> list[bytes]:
    out, pos, i = [], 0, 0
    while pos < len(wire):
        n = sizes[i % len(sizes)]
        out.append(wire[pos:pos + n])
        pos += n
        i += 1
    return out


def _rate(chunks: list[bytes]) -> float:
    best = []
    for _ in range(REPEATS):
        dec = StreamDecoder("device")
        t0 = time.perf_counter()
        n = 0
        for c in chunks:
            n += len(dec.feed(c))
        dt = time.perf_counter() - t0
        assert n == N_FRAMES and dec.stats.errors_total == 0 and dec.stats.frames_lost == 0
        best.append(n / dt)
    return statistics.median(best)


def run() -> dict[str, float]:
    try:
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    except (AttributeError, OSError):
        pass
    rng = random.Random(0)
    wire = _wire(rng)
    realistic = [max(1, int(math.exp(rng.uniform(0, math.log(512))))) for _ in range(4096)]
    r = _rate(_chunks(wire, realistic))
    r64 = _rate(_chunks(wire, [64]))
    r4k = _rate(_chunks(wire, [4096]))
    return {
        "decode_frames_per_s": round(r),
        "decode_frames_per_s_chunk64": round(r64),
        "decode_frames_per_s_chunk4096": round(r4k),
        "decode_core_share_16_fingertips_80hz_pct": round(100 * 16 * 80 / r, 4),
    }


DESCRIPTION = {
    "decode_frames_per_s": ("4-channel sample frames decoded per second, chunks of 1-512 B "
                            "(log-uniform), one core", (">=", 200_000)),
    "decode_frames_per_s_chunk64": ("same, fixed 64-byte chunks", None),
    "decode_frames_per_s_chunk4096": ("same, fixed 4096-byte chunks", None),
    "decode_core_share_16_fingertips_80hz_pct": (
        "share of one core to decode 16 fingertips at 80 Hz (percent)", ("<", 1.0)),
}
