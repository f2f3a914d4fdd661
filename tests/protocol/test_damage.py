"""A long stream with injected damage: nothing damaged is accepted, nothing intact is lost.

Damage: bit flips at a bit error rate of 1e-3, plus dropped and inserted bytes. A frame is
*intact* when none of its bytes, its own delimiter, or the delimiter before it was touched
(a damaged delimiter before it merges it with the previous frame). CRC-16 catches every error
of up to 3 bits in frames of this size; other damage slips through with odds of about
1 in 65536 per damaged frame, and the structure checks (type, length, channel count) lower
that further. The seed is fixed, so the run is the same every time.
"""
from __future__ import annotations

import bisect
import random

import pytest

from fingertip.protocol import Info, Log, Sample, Stats, StreamDecoder, encode

BER = 1e-3
DROP_RATE = 1e-4   # per byte
INSERT_RATE = 1e-4  # per byte
N_FRAMES = 30_000


def make_messages(rng: random.Random, n: int) -> list:
    msgs = []
    seq, t = 50_000, 4_294_000_000  # both counters wrap during the run
    for i in range(n):
        s = seq & 0xFFFF
        t = (t + 12_500) & 0xFFFFFFFF
        r = i % 100
        if r == 50:
            msgs.append(Stats(s, t, frames_sent=i, longest_loop_us=rng.randrange(1 << 16)))
        elif r == 75:
            msgs.append(Log(s, 1, f"note {i}"))
        elif r == 99:
            msgs.append(Info(s, 1, 0, (0, 1, 0), 0xDEADBEEF, 0, 1, 4, 80, 1, 128, 1, 0,
                             (0, 0, 0, 0)))
        else:
            values = tuple(rng.randint(-(1 << 23), (1 << 23) - 1) if rng.random() < 0.5
                           else rng.randint(-3000, 3000) for _ in range(4))
            msgs.append(Sample(s, t, values))
        seq += 1
    return msgs


def positions(rng: random.Random, rate: float, limit: int):
    """Event positions of a Bernoulli process with the given rate (geometric gaps)."""
    pos = -1
    while True:
        pos += int(rng.expovariate(rate)) + 1
        if pos >= limit:
            return
        yield pos


def damage(rng: random.Random, wire: bytes):
    """Return the damaged stream and the set of original byte indices that were touched."""
    flips: dict[int, int] = {}
    for bit in positions(rng, BER, len(wire) * 8):
        flips[bit // 8] = flips.get(bit // 8, 0) ^ (1 << (bit % 8))
    drops = set(positions(rng, DROP_RATE, len(wire)))
    inserts = {p: bytes([rng.randrange(256)]) for p in positions(rng, INSERT_RATE, len(wire))}
    touched = set(flips) | drops | set(inserts)
    out = bytearray()
    last = 0
    for p in sorted(touched):
        out += wire[last:p]
        out += inserts.get(p, b"")
        if p not in drops:
            out.append(wire[p] ^ flips.get(p, 0))
        last = p + 1
    out += wire[last:]
    return bytes(out), touched


@pytest.mark.parametrize("seed", [1, 2])
def test_damaged_stream(seed):
    rng = random.Random(seed)
    msgs = make_messages(rng, N_FRAMES)
    encoded = [encode(m) for m in msgs]
    wire = b"".join(encoded)
    ends, pos = [], 0
    for e in encoded:
        pos += len(e)
        ends.append(pos - 1)  # index of the frame's delimiter
    damaged_wire, touched = damage(rng, wire)
    touched_sorted = sorted(touched)

    def any_touched(lo: int, hi: int) -> bool:
        i = bisect.bisect_left(touched_sorted, lo)
        return i < len(touched_sorted) and touched_sorted[i] <= hi

    intact = []
    for k, end in enumerate(ends):
        start = ends[k - 1] + 1 if k else 0
        prev_delim_ok = k == 0 or ends[k - 1] not in touched
        intact.append(prev_delim_ok and not any_touched(start, end))
    n_damaged = intact.count(False)
    assert 0.05 * N_FRAMES < n_damaged < 0.5 * N_FRAMES, "the test must actually damage"

    dec = StreamDecoder("device")
    out = []
    for i in range(0, len(damaged_wire), 509):  # odd chunk size: frames straddle chunks
        out += dec.feed(damaged_wire[i:i + 509])

    index_by_seq = {m.seq: k for k, m in enumerate(msgs)}  # unique: fewer than 65536 frames
    accepted_idx = []
    for m in out:
        k = index_by_seq.get(m.seq)
        assert k is not None and m == msgs[k], f"a damaged frame was accepted: {m}"
        accepted_idx.append(k)
    assert accepted_idx == sorted(set(accepted_idx)), "frames out of order or duplicated"
    accepted = set(accepted_idx)
    # Every intact frame is recovered.
    missing = [k for k, ok in enumerate(intact) if ok and k not in accepted]
    assert not missing, f"{len(missing)} intact frames lost, first {missing[:5]}"

    st = dec.stats
    assert st.frames_ok == len(out)
    assert st.bytes_in == len(damaged_wire)
    lo, hi = accepted_idx[0], accepted_idx[-1]
    lost_between = [k for k in range(lo, hi + 1) if k not in accepted]
    runs = sum(1 for k in lost_between if k - 1 not in lost_between)
    assert st.frames_lost == len(lost_between)
    assert st.seq_gaps == runs
    # Each run of lost frames left at least one counted error behind.
    assert st.errors_total >= runs
    assert st.device_resets == 0
    print(f"seed {seed}: {n_damaged} damaged frames of {N_FRAMES}, {len(lost_between)} lost, "
          f"errors {st.errors}")
