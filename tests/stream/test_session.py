"""A fingertip's stream session, called as the command line calls it, against the virtual
device on a real pty."""
from __future__ import annotations

import json
import os

import pytest

from fingertip.stream import StreamError, StreamSettings, stream_fingertip
from fingertip.transport import TransportError


def test_count_frames_as_json_after_a_tare(port):
    lines: list[str] = []
    res = stream_fingertip(StreamSettings(count=20, json=True, tare=4), port=port,
                           out=lines.append)
    frames = [json.loads(x) for x in lines]
    assert len(frames) == 20 and all(f["counts"] == [0, 0, 0, 0] for f in frames)
    assert "force_n" not in frames[0]
    seqs = [f["seq"] for f in frames]
    assert seqs == list(range(seqs[0], seqs[0] + 20))
    assert res.frames == 20 and res.frames_lost == 0 and res.crc_errors == 0
    assert res.text().startswith(
        "20 frames; lost 0, CRC errors 0, reconnects 0, device resets 0, COBS errors 0")


def test_text_lines_or_a_live_line_and_the_settings_reach_the_device(port):
    lines: list[str] = []
    stream_fingertip(StreamSettings(count=3, rate=10, gain=32), port=port, out=lines.append)
    # Gain 32 of 128: a quarter of the counts; 10 SPS: 0.1 s between frames.
    assert len(lines) == 3 and lines[0].split()[2:] == ["250", "500", "-750", "1"]
    t = [float(x.split()[1]) for x in lines]
    assert t[1] - t[0] == pytest.approx(0.1, abs=1e-3)
    live: list[str] = []
    lines.clear()
    res = stream_fingertip(StreamSettings(duration=0.5), port=port, out=lines.append,
                           live=live.append)
    assert not lines and res.frames >= 1  # at 10 SPS (kept by the device), shown live
    assert live and live[0].split()[:2] == ["1", "frames"]
    assert "lost 0 crc 0" in live[-1]


def test_a_plot_to_png_and_no_screen_for_a_window(port, tmp_path, monkeypatch):
    png = tmp_path / "live.png"
    res = stream_fingertip(StreamSettings(count=100, plot_png=str(png)), port=port,
                           out=lambda _: None)
    assert res.frames == 100 and png.stat().st_size > 5_000
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    # Refused before any port is opened: a missing port would otherwise be the error.
    with pytest.raises(StreamError, match="--plot-png"):
        stream_fingertip(StreamSettings(count=1, plot=True), port=str(tmp_path / "nope"),
                         out=lambda _: None)


def test_a_missing_force_model_is_refused_and_a_missing_port_is_the_devices_error(port,
                                                                                 tmp_path):
    with pytest.raises(StreamError, match="--force-model refused"):
        stream_fingertip(StreamSettings(count=1, force_model=str(tmp_path / "no.onnx")),
                         port=port, out=lambda _: None)
    with pytest.raises(TransportError, match="does not exist"):
        stream_fingertip(StreamSettings(count=1), port=str(tmp_path / "nope"),
                         out=lambda _: None)
    assert os.path.exists(port)  # the device is still served: nothing was left open on it
