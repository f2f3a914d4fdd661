"""A recorder killed with SIGKILL leaves a file readable up to its last flushed chunk."""
from __future__ import annotations

import select
import signal
import subprocess
import sys
import time

import pytest
from mcap.exceptions import EndOfFile
from mcap.records import Message
from mcap.stream_reader import StreamReader

from fingertip.record import Recording

from .conftest import RATE

FLUSH = 0.5
SLACK = 0.2
"""Seconds of delivery and scheduling latency allowed on top of the flush interval (the
frame's trip through the serial link, the callback and the queue; a loaded machine)."""


def read_line(stream, timeout: float) -> str:
    deadline = time.monotonic() + timeout
    buf = b""
    while time.monotonic() < deadline:
        ready, _, _ = select.select([stream], [], [], 0.1)
        if ready:
            c = stream.read1(1) if hasattr(stream, "read1") else stream.read(1)
            if not c:
                break
            buf += c
            if c == b"\n":
                break
    return buf.decode(errors="replace")


def record_then_kill(port, path, seconds: float, *extra: str) -> tuple[float, float]:
    """Run `python -m fingertip.record record` on ``port`` into ``path``, SIGKILL it
    ``seconds`` after it said it is recording; (time it said so, time of the kill)."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "fingertip.cli", "record", "--port", str(port),
         "-o", str(path), "--name", "index", "--flush-interval", str(FLUSH), *extra],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        line = read_line(proc.stderr, 20)
        assert "recording index" in line, line + proc.stderr.read1(10000).decode()
        t_started = time.monotonic()
        time.sleep(seconds)
        t_kill = time.monotonic()
        proc.send_signal(signal.SIGKILL)
        proc.wait(5)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        proc.stderr.close()
    assert proc.returncode == -signal.SIGKILL
    return t_started, t_kill


@pytest.mark.realtime
@pytest.mark.parametrize("seconds", [2.0, 2.45])
def test_sigkill_loses_at_most_the_unflushed_chunk(device, tmp_path, seconds):
    path = tmp_path / "killed.mcap"
    t_started, t_kill = record_then_kill(device.link, path, seconds)

    rec = Recording(path)
    assert not rec.complete
    frames = [r.msg for r in rec.records(kinds=("raw",))]
    assert rec.truncated and "recording interrupted" in rec.problem
    # Nothing missing inside: one frame every 12.5 ms of device time.
    steps = {b.device_time_us - a.device_time_us
             for a, b in zip(frames, frames[1:], strict=False)}
    assert steps <= {12_496, 12_500, 12_504}
    # Both processes read the same CLOCK_MONOTONIC: how much of the end was lost? (From the
    # first frame's time, so that the recorder's start-up does not count as a loss.)
    first = rec.timebase.to_monotonic(frames[0].stamp_ns)
    assert abs(first - t_started) < 0.5
    elapsed = t_kill - first
    lost_s = t_kill - rec.timebase.to_monotonic(frames[-1].stamp_ns)
    expected = (elapsed - FLUSH - SLACK) * RATE
    print(f"\nSIGKILL {elapsed:.2f} s after the first frame: {len(frames)} frames readable "
          f"(at least {expected:.0f} required); last frame {lost_s * 1000:.0f} ms before the "
          f"kill; file {path.stat().st_size} bytes")
    assert len(frames) >= expected
    assert lost_s <= FLUSH + SLACK
    assert rec.info("index")["info"]["channels"] == 4

    # The mcap package's own sequential reader gets the same messages, then EndOfFile.
    n = 0
    with open(path, "rb") as f:
        with pytest.raises(EndOfFile):
            for record in StreamReader(f).records:
                n += isinstance(record, Message)
    assert n == sum(1 for _ in Recording(path).records())


def test_every_truncation_reads_as_a_prefix(session, tmp_path):
    """Cut a complete recording anywhere: the reader returns a prefix of its messages and
    never raises."""
    data = session.path.read_bytes()
    full = [(r.topic, r.log_time) for r in Recording(session.path).records()]
    cut = tmp_path / "cut.mcap"
    step = max(1, len(data) // 150)
    for size in [*range(8, len(data), step), len(data) - 1]:
        cut.write_bytes(data[:size])
        rec = Recording(cut)
        got = [(r.topic, r.log_time) for r in rec.records()]
        assert got == full[:len(got)], size
        assert rec.truncated or len(got) == len(full)
        assert not rec.complete
    assert len(got) == len(full)  # only the footer and summary were missing


def test_damaged_chunk_stops_reading_there(session, tmp_path):
    data = bytearray(session.path.read_bytes())
    full = sum(1 for _ in Recording(session.path).records())
    mid = len(data) // 2
    data[mid:mid + 64] = bytes(64)
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    rec = Recording(bad)
    n = sum(1 for _ in rec.records())
    assert 0 < n < full and rec.truncated and rec.problem
