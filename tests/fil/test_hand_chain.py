"""A whole hand on one Uno: the 16-channel firmware in simavr with 16 simulated HX711s, through
the real host chain on the command line (`stream` and `record` with `--hand-split 4x4`):
frames per fingertip, forces per fingertip, four microphones on four topics."""
from __future__ import annotations

import json
import subprocess
import sys
import time

import numpy as np
import soundfile as sf

from fingertip.record.reader import Recording
from tests.record.models import linear

FINGERS = ["index", "middle", "ring", "thumb"]


def value(ch: int) -> int:
    # distinct per channel, negative on odd channels (sign extension through the split)
    return (1000 * (ch + 1)) * (-1 if ch % 2 else 1)


def started_sim(make_sim):
    sim = make_sim(16)
    for ch in range(16):
        sim.set(ch, value(ch))
    sim.go()
    time.sleep(0.3)   # boot; the host asks the firmware for its INFO when it opens
    return sim


def cli(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "fingertip.cli", *args],
                          capture_output=True, text=True, timeout=timeout)


def test_stream_hand_split_4x4(make_sim):
    sim = started_sim(make_sim)
    r = cli("stream", "--port", sim.pty, "--hand-split", "4x4", "--finger-names",
            ",".join(FINGERS), "--json", "--count", "40", "--rate", "80")
    assert r.returncode == 0, r.stderr
    lines = [json.loads(x) for x in r.stdout.splitlines()]
    assert len(lines) == 40
    by = {}
    for x in lines:
        by.setdefault(x["finger"], []).append(x)
    assert list(by) == FINGERS and all(len(v) == 10 for v in by.values())
    for k, f in enumerate(FINGERS):
        for x in by[f]:
            assert x["counts"] == [value(c) for c in range(4 * k, 4 * k + 4)]
            assert x["timeout_mask"] == 0 and x["saturation_mask"] == 0
    # the four fingers of one device frame share its sequence number and device time
    seqs = [[x["seq"] for x in by[f]] for f in FINGERS]
    assert all(s == seqs[0] for s in seqs)
    assert "lost 0, CRC errors 0" in r.stderr


def test_record_hand_frames_forces_and_four_microphones(make_sim, tmp_path):
    fs = 44100
    n = int(fs * 2.5)
    t = np.arange(n)
    # one 4-input interface stands in as a 4-channel file: input k is finger k's piezo
    audio = np.stack([(np.sin(t * 0.01 * (k + 1)) * 4000 * (k + 1)).astype(np.int16)
                      for k in range(4)], axis=1)
    wav = tmp_path / "hand4.wav"
    sf.write(wav, audio, fs, subtype="PCM_16")
    sim = started_sim(make_sim)
    out = tmp_path / "hand.mcap"
    r = cli("record", "--port", sim.pty, "--hand-split", "4x4", "--finger-names",
            ",".join(FINGERS), "--hand-audio", str(wav), "--force-model",
            "tests.record.models:linear", "--duration", "2", "-o", str(out))
    assert r.returncode == 0, r.stderr
    assert "dropped 0" in r.stderr
    rec = Recording(out)
    assert rec.complete
    assert rec.devices() == sorted(FINGERS)
    got: dict[str, dict[str, list]] = {f: {} for f in FINGERS}
    for m in rec.records():
        got[m.name].setdefault(m.kind, []).append(m.msg)
    raw_n = {f: len(got[f]["raw"]) for f in FINGERS}
    assert min(raw_n.values()) >= 20 and len(set(raw_n.values())) == 1, raw_n
    for k, f in enumerate(FINGERS):
        chans = [value(c) for c in range(4 * k, 4 * k + 4)]
        assert all(list(m.counts) == chans for m in got[f]["raw"])
        wr = got[f]["wrench"]
        assert len(wr) == raw_n[f]
        fx, fy = linear(chans)
        assert all(abs(w.force[0] - fx) < 1e-9 and abs(w.force[1] - fy) < 1e-9 for w in wr)
        assert [e.kind for e in got[f]["events"]] == ["start", "stop"]
        pcm = np.concatenate([np.frombuffer(a.data, "<i2") for a in got[f]["audio"]])
        assert len(pcm) >= fs * 1.5
        np.testing.assert_array_equal(pcm, audio[:len(pcm), k])
    assert rec.info("index")["channels"] == [0, 1, 2, 3]
    assert rec.info("thumb")["channels"] == [12, 13, 14, 15]


def test_hand_split_needs_the_16_channel_firmware(make_sim):
    sim = make_sim(4)
    sim.go()
    time.sleep(0.3)
    r = cli("stream", "--port", sim.pty, "--hand-split", "4x4", "--count", "4")
    assert r.returncode == 2
    lines = [x for x in r.stderr.splitlines() if x.strip()]
    assert len(lines) == 1 and "needs 16 channels" in lines[0] and "--channels 16" in lines[0]
