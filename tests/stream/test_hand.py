"""A hand's stream session: every finger's frames under its name, against virtual devices
on real ptys."""
from __future__ import annotations

import json

import pytest

from fingertip.hand_args import HandSpec
from fingertip.sim import VirtualFirmware
from fingertip.sim.device.pty_device import PtyDevice
from fingertip.stream import StreamError, StreamSettings, stream_hand


def test_two_fingers_json_and_counters(tmp_path):
    fws = [VirtualFirmware(4, source=lambda t, k=k: (k, 2, 3, 4)) for k in (1, 2)]
    with PtyDevice(fws[0], link=tmp_path / "a") as a, PtyDevice(fws[1], link=tmp_path / "b") as b:
        spec = HandSpec(ports={"index": str(a.link), "thumb": str(b.link)})
        lines: list[str] = []
        res = stream_hand(StreamSettings(count=40, json=True), spec, out=lines.append)
        rows = [json.loads(x) for x in lines]
        assert len(rows) == 40 and {r["finger"] for r in rows} == {"index", "thumb"}
        assert all(r["counts"][0] == (1 if r["finger"] == "index" else 2) for r in rows)
        text = res.text().splitlines()
        assert text[0] == (f"{a.link}: lost 0, CRC errors 0, reconnects 0, device resets 0, "
                           "COBS errors 0")
        assert text[-1] == "40 finger frames (index, thumb); hand queue overruns 0"
        lines.clear()
        stream_hand(StreamSettings(count=2), spec, out=lines.append)
        assert len(lines) == 2 and all(x.split()[0] in ("index", "thumb") for x in lines)


def test_refusals(tmp_path):
    with pytest.raises(StreamError, match="--plot shows one fingertip"):
        stream_hand(StreamSettings(plot_png=str(tmp_path / "p.png")),
                    HandSpec(ports={"index": "/nonexistent"}), out=print)
    with PtyDevice(VirtualFirmware(4), link=tmp_path / "a") as a:
        spec = HandSpec(groups={"index": (0, 1), "thumb": (4, 5)}, port=str(a.link))
        with pytest.raises(StreamError, match="channel"):
            stream_hand(StreamSettings(count=1), spec, out=print)
