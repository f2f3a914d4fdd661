"""The `fingertip` console script, run as users run it."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from fingertip.protocol import Sample, Stats, encode

EXE = Path(sys.executable).with_name("fingertip")


def run(*args, stdin=None):
    return subprocess.run([str(EXE), *args], capture_output=True, input=stdin, timeout=60)


def test_version():
    r = run("--version")
    assert r.returncode == 0 and b"wire protocol v1.0" in r.stdout


def test_decode_capture(tmp_path):
    cap = tmp_path / "capture.bin"
    cap.write_bytes(encode(Sample(1, 10, (1, 2, 3, 4))) + b"\x07\x07\x00"
                    + encode(Stats(2, 20)) + encode(Sample(4, 30, (5, 6, 7, 8)))[:9])
    r = run("decode", str(cap), "--json")
    assert r.returncode == 1  # errors were found
    lines = [json.loads(x) for x in r.stdout.decode().splitlines()]
    assert [x["type"] for x in lines] == ["sample", "stats"]
    counters = json.loads(r.stderr.decode().splitlines()[-1])["counters"]
    assert counters["cobs_errors"] == 1 and counters["frames_ok"] == 2
    assert counters["unterminated_bytes"] == 9


def test_decode_missing_file_is_a_clear_error(tmp_path):
    r = run("decode", str(tmp_path / "nope.bin"))
    assert r.returncode == 2 and b"cannot read" in r.stderr
