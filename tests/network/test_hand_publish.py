"""`publish --hand index=PORT,middle=PORT --hand-audio index=CARD,middle=CARD`: a hand of one
virtual fingertip per finger (each behind its own pty), each finger's microphone a mono
card (a WAV standing in), received by `record --from dds` in another process."""
from __future__ import annotations

import signal
import time

import numpy as np
import soundfile as sf

from fingertip.record.reader import Recording
from fingertip.sim import VirtualFirmware
from fingertip.sim.device.pty_device import PtyDevice
from tests.firmware.in_loop.test_hand_chain import by_finger

from .conftest import start, wait_line

FINGERS = ("index", "middle")


def test_publish_a_hand_of_two_devices_with_a_card_each(tmp_path):
    fs = 44100
    wavs = {}
    for k, f in enumerate(FINGERS):
        x = (np.sin(np.arange(fs * 4) * 0.02 * (k + 1)) * 5000).astype(np.int16)
        wavs[f] = (tmp_path / f"{f}.wav", x)
        sf.write(wavs[f][0], x, fs, subtype="PCM_16")
    devs = [PtyDevice(VirtualFirmware(4, source=lambda t, k=k: (k + 1,) * 4),
                      link=tmp_path / f).start() for k, f in enumerate(FINGERS)]
    remote = tmp_path / "remote.mcap"
    try:
        sub = start("record", "--from", "dds", "--name", ",".join(FINGERS), "-o", str(remote))
        try:
            wait_line(sub, "recording index")
            pub = start("publish", "--hand", ",".join(f"{f}={tmp_path / f}" for f in FINGERS),
                        "--hand-audio", ",".join(f"{f}={wavs[f][0]}" for f in FINGERS),
                        "--duration", "2", "--wait-subscribers", "1", "--wait-timeout", "30")
            _, err = pub.communicate(timeout=90)
            assert pub.returncode == 0, err
            time.sleep(0.5)
        finally:
            sub.send_signal(signal.SIGTERM)
            _, sub_err = sub.communicate(timeout=30)
        assert sub.returncode == 0, sub_err
    finally:
        for d in devs:
            d.stop()
    rec = Recording(remote)
    assert rec.devices() == sorted(FINGERS)
    got = by_finger(rec, FINGERS)
    for k, f in enumerate(FINGERS):
        assert len(got[f]["raw"]) >= 60
        assert all(tuple(m.counts) == (k + 1,) * 4 for m in got[f]["raw"])
        pcm = np.concatenate([np.frombuffer(a.data, "<i2") for a in got[f]["audio"]])
        assert len(pcm) >= fs
        np.testing.assert_array_equal(pcm, wavs[f][1][:len(pcm)])


def test_publish_refuses_bad_hand_options_in_one_line(tmp_path):
    for args, msg in [
        (["--hand", "index=/dev/null", "--name", "x"], "use --finger-names"),
        (["--hand", "index=/dev/null", "--virtual-audio"], "given with --hand-audio"),
        (["--port", "A", "--port", "B", "--hand-split", "4x4"], "give one --port, not 2"),
        (["--virtual", "1", "--hand-split", "4x4"], "give it with --port or --serial"),
    ]:
        p = start("publish", *args, "--duration", "1")
        _, err = p.communicate(timeout=60)
        lines = [x for x in err.splitlines() if x.strip()]
        assert p.returncode == 2 and len(lines) == 1 and msg in lines[0], (args, err)
