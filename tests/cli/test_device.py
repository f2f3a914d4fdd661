"""`fingertip devices|info|tare|stream|sim device`, run as a user runs them."""
from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path


EXE = str(Path(sys.executable).with_name("fingertip"))


def run(*args, timeout=30):
    return subprocess.run([EXE, *args], capture_output=True, text=True, timeout=timeout)


def test_info_tare_stream(port):
    r = run("info", "--port", port, "--json")
    assert r.returncode == 0, r.stderr
    info = json.loads(r.stdout)["info"]
    assert info["channels"] == 4 and info["protocol_major"] == 1
    r = run("tare", "--port", port, "--samples", "4")
    assert r.returncode == 0 and "1000, 2000, -3000, 4" in r.stdout
    r = run("stream", "--port", port, "--count", "20", "--json")
    assert r.returncode == 0, r.stderr
    frames = [json.loads(x) for x in r.stdout.splitlines()]
    assert len(frames) == 20 and all(f["counts"] == [0, 0, 0, 0] for f in frames)
    assert "lost 0" in r.stderr


def test_wrong_port_and_missing_arguments_are_clear(tmp_path):
    r = run("info", "--port", str(tmp_path / "nope"))
    assert r.returncode == 2 and "does not exist" in r.stderr
    r = run("info")
    assert r.returncode == 2 and "--port" in r.stderr
    r = run("info", "--serial", "NO-SUCH-SERIAL")
    assert r.returncode == 2 and "no serial port with USB serial number" in r.stderr
    r = run("tare", "--port", str(tmp_path / "nope"), "--samples", "x")
    assert r.returncode == 2 and "invalid int" in r.stderr


def test_devices_lists_ports():
    r = run("devices", "--all", "--json")
    assert r.returncode == 0 and isinstance(json.loads(r.stdout), list)


def test_sim_device_serves_a_fingertip(tmp_path):
    link = tmp_path / "vft"
    p = subprocess.Popen([EXE, "sim", "device", "--link", str(link)], stdout=subprocess.PIPE,
                         text=True)
    try:
        assert "virtual fingertip on" in p.stdout.readline()
        r = run("stream", "--port", str(link), "--count", "10", "--json")
        assert r.returncode == 0, r.stderr
        assert len(r.stdout.splitlines()) == 10
    finally:
        p.send_signal(signal.SIGTERM)
        p.wait(timeout=10)
    assert p.returncode == 0
    time.sleep(0.1)
    assert not link.exists()


def test_stream_live_plot_to_png_and_no_display_error(port, tmp_path):
    png = tmp_path / "live.png"
    r = run("stream", "--port", port, "--count", "100", "--plot-png", str(png))
    assert r.returncode == 0, r.stderr
    assert png.exists() and png.stat().st_size > 5_000
    import os
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    r = subprocess.run([EXE, "stream", "--port", port, "--count", "1", "--plot"],
                       capture_output=True, text=True, timeout=30, env=env)
    assert r.returncode == 2 and "--plot-png" in r.stderr


def test_stream_sets_rate_and_gain(port):
    r = run("stream", "--port", port, "--count", "3", "--json", "--rate", "10", "--gain", "32")
    assert r.returncode == 0, r.stderr
    assert len(r.stdout.splitlines()) == 3
    info = json.loads(run("info", "--port", port, "--json").stdout)["info"]
    assert info["rate_sps"] == 10 and info["gain"] == 32
