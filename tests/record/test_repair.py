"""``fingertip repair``: a recorder killed at random moments leaves a file that, repaired,
opens in the ``mcap`` package's ordinary reader and in ``rosbags``, with every message
that reached the disk and no more lost than the flush interval allows."""
from __future__ import annotations

import json
import random
import struct
import subprocess
import sys
from pathlib import Path

import pytest
from mcap.reader import make_reader

from fingertip.badfile import BadFileError
from fingertip.record import Recording
from fingertip.record.repair import repair

from .conftest import RATE
from .test_crash import FLUSH, record_then_kill

SLACK = 0.3
"""Seconds of delivery and scheduling latency allowed on top of the flush interval (the
frame's trip through the link and queue, on a machine shared with other test runs)."""
KILLS = 20


def mcap_messages(path: Path) -> list[tuple[str, int]]:
    """(topic, log_time) of every message, read the way other tools read: the indexed
    reader that seeks to the footer."""
    with open(path, "rb") as f:
        return [(ch.topic, m.log_time) for _, ch, m in make_reader(f).iter_messages()]


def rosbags_count(path: Path) -> dict[str, int]:
    """Messages per topic through rosbags, every one deserialised."""
    from rosbags.highlevel import AnyReader

    out: dict[str, int] = {}
    with AnyReader([path]) as r:
        for conn, _, raw in r.messages():
            r.deserialize(raw, conn.msgtype)
            out[conn.topic] = out.get(conn.topic, 0) + 1
    return out


@pytest.mark.realtime
def test_random_sigkills_then_repair(device, tmp_path, session):
    """KILLS recorder processes (frames, forces from an ONNX-free callable, audio from a
    file) each killed 0.5-3 s after it started streaming, at random."""
    wav = tmp_path / "tone.wav"
    import numpy as np
    import soundfile as sf

    t = np.arange(44100 * 4) / 44100
    sf.write(wav, 0.3 * np.sin(2 * np.pi * 440 * t), 44100, subtype="PCM_16")
    rng = random.Random(18)
    lost_frames, lost_s_all, cut_inside = [], [], 0
    for k in range(KILLS):
        path = tmp_path / f"killed{k}.mcap"
        _, t_kill = record_then_kill(device.link, path, rng.uniform(0.5, 3.0), "--audio-file",
                                     str(wav), "--force-model", "tests.record.models:linear")
        with pytest.raises(Exception):  # noqa: B017 - the ordinary reader fails first
            mcap_messages(path)
        before = [(r.topic, r.log_time) for r in Recording(path).records()]
        res = repair(path)
        cut_inside += res.tail_bytes > 0
        after = mcap_messages(res.output)
        # Every message our crash-tolerant reader saw is in the copy, in the same order.
        assert sorted(after) == sorted(before), k
        assert res.kept == len(after)
        counts = rosbags_count(res.output)
        assert sum(counts.values()) == len(after)
        frames = [r.msg for r in Recording(res.output).records(kinds=("raw",))]
        assert Recording(res.output).complete
        if not frames:  # killed before the first flush: nothing to count against
            lost_frames.append(None)
            continue
        rec = Recording(res.output)
        last = rec.timebase.to_monotonic(frames[-1].stamp_ns)
        lost_s = t_kill - last
        lost_s_all.append(lost_s)
        lost_frames.append(round(lost_s * RATE))
        assert lost_s <= FLUSH + SLACK, (k, lost_s)
        assert counts.get("/fingertip/index/wrench") == len(frames)
        steps = {b.device_time_us - a.device_time_us
                 for a, b in zip(frames, frames[1:], strict=False)}
        assert steps <= {12_496, 12_500, 12_504}, (k, sorted(steps)[-5:], [  # nothing missing
            (a.seq, b.seq) for a, b in zip(frames, frames[1:], strict=False)
            if b.device_time_us - a.device_time_us > 12_504])
    got = [x for x in lost_frames if x is not None]
    print(f"\n{KILLS} SIGKILLs: frames lost at the end {got} (flush {FLUSH} s = "
          f"{FLUSH * RATE:.0f} frames); max {max(lost_s_all):.3f} s; files cut inside a "
          f"record: {cut_inside}")
    assert len(got) >= KILLS // 2


def test_every_truncation_repairs_to_a_prefix(session, tmp_path):
    data = session.path.read_bytes()
    full = mcap_messages(session.path)
    cut = tmp_path / "cut.mcap"
    step = max(1, len(data) // 60)
    for size in [8, 9, 20, *range(30, len(data), step), len(data) - 1]:
        cut.write_bytes(data[:size])
        res = repair(cut, tmp_path / "fixed.mcap", overwrite=True)
        got = mcap_messages(res.output)
        ours = [(r.topic, r.log_time) for r in Recording(cut).records()]
        assert sorted(got) == sorted(ours), size  # all that our own reader recovers
        assert set(got) <= set(full)
        assert res.kept == len(got)
        assert not res.was_complete
    assert len(got) == len(full)  # only the footer and summary were missing


def test_a_damaged_chunk_is_skipped_and_the_rest_kept(session, tmp_path):
    data = bytearray(session.path.read_bytes())
    full = mcap_messages(session.path)
    # Find the chunk records (opcode 0x06) and damage the body of the first one.
    pos, chunks = 8, []
    while pos < len(data):
        op, n = struct.unpack_from("<BQ", data, pos)
        if op == 0x06:
            chunks.append((pos, n))
        if op == 0x02:
            break
        pos += 9 + n
    assert len(chunks) >= 2
    for which in (0, 1):  # the first chunk also holds the channel definitions
        p, n = chunks[which]
        damaged = bytearray(data)
        damaged[p + 9 + n - 20:p + 9 + n - 4] = bytes(16)  # inside the compressed records
        bad = tmp_path / f"bad{which}.mcap"
        bad.write_bytes(bytes(damaged))
        res = repair(bad)
        got = mcap_messages(res.output)
        assert len(res.damaged_records) == 1 and res.damaged_records[0][0] == p
        assert 0 < len(got) < len(full) and set(got) <= set(full)
        assert res.orphan_messages == 0  # definitions taken from the summary
        assert "skipped 1 damaged record" in res.summary()
        # Cut short as well (no summary to fall back on): the rest of the file still counts.
        bad.write_bytes(bytes(damaged[:len(data) - 100]))
        res = repair(bad, overwrite=True)
        assert len(res.damaged_records) == 1
        assert res.kept == len(mcap_messages(res.output))


def test_complete_file_is_copied_whole(session, tmp_path):
    res = repair(session.path, tmp_path / "copy.mcap")
    assert res.was_complete and not res.lost_anything
    assert mcap_messages(res.output) == mcap_messages(session.path)
    assert "nothing lost" in res.summary()


def test_refusals(session, tmp_path):
    with pytest.raises(BadFileError, match="not an MCAP file"):
        (tmp_path / "x.mcap").write_bytes(b"hello world, not mcap")
        repair(tmp_path / "x.mcap")
    with pytest.raises(BadFileError, match="must not replace"):
        repair(session.path, session.path)
    out = tmp_path / "o.mcap"
    out.write_bytes(b"")
    with pytest.raises(FileExistsError):
        repair(session.path, out)


def test_command_line(session, tmp_path):
    cut = tmp_path / "cut.mcap"
    data = session.path.read_bytes()
    cut.write_bytes(data[:len(data) * 2 // 3])
    r = subprocess.run([sys.executable, "-m", "fingertip.cli", "repair", str(cut), "--json"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["output"] == str(tmp_path / "cut.repaired.mcap") and d["kept"] > 0
    assert "repaired" in r.stderr and "kept" in r.stderr
    assert len(mcap_messages(Path(d["output"]))) == d["kept"]
    r = subprocess.run([sys.executable, "-m", "fingertip.cli", "repair", str(cut)],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "already exists" in r.stderr
    r = subprocess.run([sys.executable, "-m", "fingertip.cli", "replay", str(cut),
                        "--as-fast-as-possible"], capture_output=True, text=True, timeout=60)
    assert "fingertip repair" in r.stderr  # the note on a cut-short file points to it
