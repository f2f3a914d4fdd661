"""`fingertip record --audio pulse`: a live device and live capture through the real audio
stack (paplay -> PulseAudio null sink -> ALSA pulse plugin -> PortAudio), into one file."""
from __future__ import annotations

import os
import subprocess
import sys
import time

import numpy as np
import pytest
import soundfile as sf

from fingertip.record import Recording, export

from ..audio.pulse import PulseError, PulseServer

pytestmark = pytest.mark.slow
FS = 44100


@pytest.fixture(scope="module")
def pulse():
    try:
        server = PulseServer()
        server.start()
    except PulseError as e:
        pytest.fail(f"cannot start a private PulseAudio server: {e}", pytrace=False)
    try:
        yield server
    finally:
        server.stop()


def test_record_device_and_sound_card(pulse, device, tmp_path):
    rng = np.random.default_rng(7)
    burst = np.concatenate([np.zeros(FS // 10), rng.integers(-20000, 20000, FS // 2),
                            np.zeros(FS // 10)]).astype(np.int16)
    wav = tmp_path / "burst.wav"
    sf.write(wav, burst, FS, subtype="PCM_16")
    out = tmp_path / "live.mcap"
    env = dict(os.environ, **pulse.client_env())
    proc = subprocess.Popen(
        [sys.executable, "-m", "fingertip.cli", "record", "--port", str(device.link),
         "-o", str(out), "--duration", "3", "--audio", "pulse", "--name", "index"],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stderr.readline()
        assert "recording index" in line, line + proc.stderr.read()
        time.sleep(0.5)
        player = pulse.play(wav)
        player.wait(10)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err
    assert "dropped 0" in err

    rec = Recording(out)
    audio = [r.msg for r in rec.records(kinds=("audio",))]
    frames = [r.msg for r in rec.records(kinds=("raw",))]
    assert len(frames) > 2.5 * 80
    assert audio and {(m.sample_rate, m.channels, m.encoding) for m in audio} == \
        {(44100.0, 1, "S16LE")}
    idx = [m.first_index for m in audio]
    assert idx == sorted(idx)
    meta = rec.channels()["/fingertip/index/audio"].metadata
    assert meta["dtype"] == "int16" and meta["sample_rate"] == "44100.0"

    res = export(out, tmp_path / "x")
    y, fs = sf.read(tmp_path / "x" / "index_audio.wav", dtype="int16")
    assert fs == FS and res.audio_gap_frames == {"index": 0}
    # The played burst is in the recording, bit-exact.
    nz = np.flatnonzero(burst)
    ynz = np.flatnonzero(y)
    assert len(ynz), "no audio captured"
    start = ynz[0] - nz[0]
    np.testing.assert_array_equal(y[start + nz[0]:start + nz[-1] + 1], burst[nz[0]:nz[-1] + 1])
    # Its time stamp falls inside the recording's frames, where it was played.
    k = [m for m in audio if m.first_index <= start + nz[0] < m.first_index + m.frames][0]
    t_burst = k.stamp_ns + (start + nz[0] - k.first_index) / k.host_rate * 1e9
    assert frames[0].stamp_ns < t_burst < frames[-1].stamp_ns
