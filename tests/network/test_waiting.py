"""Waiting says so: `record --from` with nobody publishing says what it waits for every few
seconds, and --wait-timeout ends it with exit 1 and one line (the pure rule, then the real
command over DDS and LSL on loopback)."""
from __future__ import annotations

import subprocess

import pytest

from fingertip.network.waiting import HINTS, Silence

from .conftest import cli, env


def test_silence_says_what_it_waits_for_every_few_seconds():
    s = Silence(["index", "thumb"], "dds", start=100.0, every_s=5.0)
    said = []
    for t in (100.0, 102.0, 104.9, 105.0, 105.1, 107.0):
        lines, end = s.check(t)
        assert end is None
        said += [(t, line) for line in lines]
        if t == 104.9:
            s.heard("thumb", t)  # thumb publishes from now on
    # At 5 s, only index is still silent; thumb was heard at 104.9.
    assert [t for t, _ in said] == [105.0]
    assert said[0][1] == ("waiting for index over dds: nothing received yet for 5 s; "
                          + HINTS["dds"])
    lines, end = s.check(110.0)
    assert [line.split(":")[0] for line in lines] == ["waiting for index over dds",
                                                      "waiting for thumb over dds"]
    assert "since the last message" in lines[1] and end is None


@pytest.mark.parametrize("source", ["dds", "zenoh", "lsl"])
def test_the_wait_timeout_ends_with_one_line_naming_what_was_awaited(source):
    s = Silence(["index"], source, start=0.0, timeout_s=12.0)
    assert s.check(11.9)[1] is None
    s.heard("index", 11.9)  # a message: the clock starts again
    assert s.check(23.8)[1] is None
    lines, end = s.check(24.0)
    assert end == (f"no messages from index over {source} for 12 s (--wait-timeout 12): "
                   + HINTS[source])
    assert "\n" not in end


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan")])
def test_a_nonsense_timeout_is_refused(bad):
    with pytest.raises(ValueError, match="wait timeout"):
        Silence(["index"], "dds", 0.0, timeout_s=bad)


@pytest.mark.parametrize("source", ["dds", "lsl"])
def test_record_from_with_no_publisher_waits_aloud_then_ends(tmp_path, source):
    if source == "lsl":
        pytest.importorskip("pylsl")
    out = tmp_path / "run.mcap"
    r = subprocess.run(cli("record", "--from", source, "--name", "nobody", "-o", str(out),
                           "--wait-timeout", "7"),
                       env=env(), capture_output=True, text=True, timeout=60)
    assert r.returncode == 1, r.stderr
    lines = r.stderr.splitlines()
    waiting = [x for x in lines if x.startswith("waiting for nobody over")]
    assert waiting and "nothing received yet for 5 s" in waiting[0]
    errors = [x for x in lines if x.startswith("ERROR")]
    assert errors == [f"ERROR fingertip: no messages from nobody over {source} for 7 s "
                      f"(--wait-timeout 7): {HINTS[source]}"]
    assert "Traceback" not in r.stderr and not out.exists()  # no empty file left behind


def test_wait_timeout_without_from_is_refused(tmp_path):
    r = subprocess.run(cli("record", "--port", str(tmp_path / "nothing"), "-o",
                           str(tmp_path / "x.mcap"), "--wait-timeout", "3"),
                       env=env(), capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "--wait-timeout is for record --from" in r.stderr
