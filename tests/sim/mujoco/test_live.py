"""A MuJoCo scene behind the virtual device and a capture source, and `fingertip sim mujoco`
run as a user runs it."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from fingertip.protocol import Sample, Start, StreamDecoder, encode
from fingertip.sim import VirtualFirmware
from fingertip.sim.mujoco.live import LiveSimulation

EXE = str(Path(sys.executable).with_name("fingertip"))


def test_the_pinch_scene_drives_the_firmware_core_at_80_sps():
    live = LiveSimulation("pinch", seed=1)
    fw = VirtualFirmware(4, source=live.counts_source())
    dec = StreamDecoder("device")
    dec.feed(fw.boot())
    dec.feed(fw.receive(encode(Start(1))))
    samples = []
    for t_us in range(10_000, 3_000_000, 10_000):
        samples += [m for m in dec.feed(fw.advance(t_us)) if isinstance(m, Sample)]
    assert dec.stats.errors_total == 0
    assert abs(len(samples) - 3 * 80) <= 8
    c = np.array([s.values for s in samples], float)
    t = np.array([s.timestamp_us for s in samples]) * 1e-6
    rest, squeeze = c[(t > 0.3) & (t < 0.7)].mean(0), c[t > 2.2].mean(0)
    # Squeezed on its -x face: channel 0 and 2 move apart by far more than the noise.
    delta = squeeze - rest
    assert abs(delta[0] - delta[2]) > 50_000


def test_the_slide_scene_is_a_capture_source():
    live = LiveSimulation("slide", seed=2)
    src = live.audio_source(realtime=False, duration=16.0)
    with src:
        y = np.concatenate([c.samples for c in src.chunks()])[:, 0]
    assert len(y) == 16 * 44100
    fs = 44100
    # The fourth plate (coarse fabric) is slid over from 13.0 s to 15.4 s.
    quiet, sliding = y[int(0.1 * fs):int(0.5 * fs)], y[int(13.5 * fs):int(15.3 * fs)]
    assert sliding.std() > 3 * quiet.std() > 0  # the texture over the noise floor and hum


def test_unknown_scene_is_refused():
    with pytest.raises(ValueError, match="unknown scene 'cups': one of slide, pinch"):
        LiveSimulation("cups")


@pytest.mark.realtime
def test_cli_serves_a_mujoco_fingertip_that_stream_reads(tmp_path):
    link = tmp_path / "mj"
    p = subprocess.Popen([EXE, "sim", "mujoco", "--scene", "pinch", "--link", str(link)],
                         stdout=subprocess.PIPE, text=True)
    try:
        assert "MuJoCo scene 'pinch'" in p.stdout.readline()
        r = subprocess.run([EXE, "stream", "--port", str(link), "--count", "20", "--json"],
                           capture_output=True, text=True, timeout=60)
        assert r.returncode == 0, r.stderr
        frames = [json.loads(x) for x in r.stdout.splitlines()]
        assert len(frames) == 20 and "lost 0" in r.stderr
    finally:
        p.send_signal(signal.SIGTERM)
        p.wait(timeout=20)
    assert p.returncode == 0
    time.sleep(0.1)
    assert not link.exists()
    r = subprocess.run([EXE, "sim", "mujoco", "--scene", "cups"], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 2 and "unknown scene 'cups'" in r.stderr


def test_cli_renders_frames_counts_and_a_summary_headless(tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    out = tmp_path / "run"
    r = subprocess.run([EXE, "sim", "mujoco", "--scene", "pinch", "--render", str(out),
                        "--seconds", "2", "--fps", "5"], capture_output=True, text=True,
                       timeout=120, env=env)
    assert r.returncode == 0, r.stderr
    frames = sorted((out / "frames").glob("frame_*.png"))
    assert len(frames) == 10 and all(f.stat().st_size > 2_000 for f in frames)
    assert (out / "summary.png").stat().st_size > 20_000
    rows = (out / "counts.csv").read_text().splitlines()
    assert rows[0].startswith("t_s,fx_n") and len(rows) == 1 + 2 * 80
    r = subprocess.run([EXE, "sim", "mujoco", "--view"], capture_output=True, text=True,
                       timeout=120, env=env)
    assert r.returncode == 2 and "no display for the viewer" in r.stderr
