"""A whole hand on one Uno: the 16-channel firmware in simavr with 16 simulated HX711s, through
the real host chain on the command line (`stream` and `record` with `--hand-split 4x4`):
frames per fingertip, forces per fingertip, four microphones on four topics."""
from __future__ import annotations

import json
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
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


def four_input_wav(tmp_path, seconds: float, amplitude: int, fs: int = 44100):
    """One 4-input interface stands in as a 4-channel file: input k is finger k's piezo."""
    t = np.arange(int(fs * seconds))
    audio = np.stack([(np.sin(t * 0.01 * (k + 1)) * amplitude * (k + 1)).astype(np.int16)
                      for k in range(4)], axis=1)
    wav = tmp_path / "hand4.wav"
    sf.write(wav, audio, fs, subtype="PCM_16")
    return wav, audio


def by_finger(rec: Recording, fingers) -> dict[str, dict[str, list]]:
    """A recording's messages: finger -> topic kind -> messages in order."""
    got: dict[str, dict[str, list]] = {f: {} for f in fingers}
    for m in rec.records():
        got[m.name].setdefault(m.kind, []).append(m.msg)
    return got


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
    wav, audio = four_input_wav(tmp_path, 2.5, 4000, fs)
    sim = started_sim(make_sim)
    out = tmp_path / "hand.mcap"
    r = cli("record", "--port", sim.pty, "--hand-split", "4x4", "--finger-names",
            ",".join(FINGERS), "--hand-audio", str(wav), "--force-model",
            "tests.record.models:linear", "--duration", "2", "-o", str(out))
    assert r.returncode == 0, r.stderr
    assert "dropped 0" in r.stderr
    # the device's own counters, not overruns of a queue the recorder never reads
    assert "devices: lost 0, CRC errors 0, reconnects 0" in r.stderr, r.stderr
    rec = Recording(out)
    assert rec.complete
    assert rec.devices() == sorted(FINGERS)
    got = by_finger(rec, FINGERS)
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


@pytest.mark.realtime
def test_publish_hand_split_4x4_to_a_subscriber_in_another_process(make_sim, tmp_path,
                                                                  monkeypatch):
    """`publish --port P --hand-split 4x4 --hand-audio 4-INPUT` over DDS on loopback: a
    `record --from dds` in another process sees the four fingertips' topics, each with its
    own channels, forces and microphone."""
    from tests.network.conftest import localhost_only, start, wait_line

    localhost_only.__wrapped__(monkeypatch)
    fs = 44100
    wav, audio = four_input_wav(tmp_path, 4, 3000, fs)
    sim = started_sim(make_sim)
    remote = tmp_path / "remote.mcap"
    sub = start("record", "--from", "dds", "--name", ",".join(FINGERS), "-o", str(remote))
    try:
        wait_line(sub, "recording index")
        pub = start("publish", "--port", sim.pty, "--hand-split", "4x4", "--finger-names",
                    ",".join(FINGERS), "--hand-audio", str(wav), "--force-model",
                    "tests.record.models:linear", "--duration", "3",
                    "--wait-subscribers", "1", "--wait-timeout", "30")
        _, err = pub.communicate(timeout=120)
        assert pub.returncode == 0, err
        assert "publishing index, middle, ring, thumb over dds" in err
        time.sleep(0.5)
    finally:
        sub.send_signal(signal.SIGTERM)
        _, sub_err = sub.communicate(timeout=30)
    assert sub.returncode == 0, sub_err
    rec = Recording(remote)
    assert rec.devices() == sorted(FINGERS)
    got = by_finger(rec, FINGERS)
    for k, f in enumerate(FINGERS):
        raw = got[f]["raw"]
        # 3 s at 80 Hz is 240; simavr running 16 channels beside two busy loops made 98-99
        # (busy series 16; beside series 18): one second of frames is enough to check the split.
        assert len(raw) >= 80, (f, len(raw))
        chans = [value(c) for c in range(4 * k, 4 * k + 4)]
        assert all(list(m.counts) == chans for m in raw)
        fx, fy = linear(chans)
        assert len(got[f]["wrench"]) == len(raw)
        assert all(abs(w.force[0] - fx) < 1e-9 and abs(w.force[1] - fy) < 1e-9
                   for w in got[f]["wrench"])
        pcm = np.concatenate([np.frombuffer(a.data, "<i2") for a in got[f]["audio"]])
        assert len(pcm) >= fs * 2 and all(a.channels == 1 for a in got[f]["audio"])
        np.testing.assert_array_equal(pcm, audio[:len(pcm), k])
        assert [e.kind for e in got[f]["events"]][:1] == ["start"]
        info = json.loads(rec.info(f)) if isinstance(rec.info(f), str) else rec.info(f)
        assert info["settings"]["device_channels"] == list(range(4 * k, 4 * k + 4))
    # one device frame -> the same sequence numbers on every finger's topic
    seqs = [[m.seq for m in got[f]["raw"]] for f in FINGERS]
    common = set(seqs[0]).intersection(*seqs[1:])
    assert len(common) >= 0.9 * min(len(s) for s in seqs)


def test_check_hand_split_4x4_reports_each_finger(make_sim, tmp_path):
    """`check --port P --hand-split 4x4` on the 16-channel firmware: one report per finger,
    and a chip missing on one finger fails that finger only."""
    sim = make_sim(16, noise=45.0, seed=3)   # the datasheet's noise: a flat line is "stuck"
    for ch in range(16):
        sim.set(ch, (100_000, -200_000, 30_000, 50_000)[ch % 4])
    sim.chip(9, "absent")   # ring = channels 8..11: its second chip
    sim.go()
    time.sleep(0.3)
    report = tmp_path / "hand.json"
    r = cli("check", "--port", sim.pty, "--hand-split", "4x4", "--finger-names",
            ",".join(FINGERS), "--no-prompt", "--no-audio", "--report", str(report),
            timeout=300)
    assert r.returncode == 1, r.stderr      # a check failed (ring's chip)
    doc = json.loads(report.read_text())
    assert [x["finger"] for x in doc["fingertips"]] == FINGERS
    assert not doc["ok"]
    for k, x in enumerate(doc["fingertips"]):
        assert x["device"]["channels"] == 4
        assert x["device"]["device_channels"] == list(range(4 * k, 4 * k + 4))
        failed = [(res["check"], res["channel"]) for res in x["results"]
                  if res["status"] == "fail"]
        if FINGERS[k] == "ring":
            assert ("chip answers", 1) in failed, failed     # finger channel 1 = device channel 9
            assert all(ch in (1, None) for _, ch in failed), failed
        else:
            assert x["ok"], failed
    for f in FINGERS:
        assert f"== {f}" in r.stdout
