"""Hand: fingers on separate devices, or one 16-channel device split into fingers."""
from __future__ import annotations

import pytest

from fingertip import Fingertip, Hand
from fingertip.sim import VirtualFirmware
from fingertip.sim.pty_device import PtyDevice


def test_four_devices(tmp_path):
    names = ["thumb", "index", "middle", "ring"]
    devs = [PtyDevice(VirtualFirmware(4, source=lambda t, k=k: (k, k, k, k)),
                      link=tmp_path / n).start() for k, n in enumerate(names)]
    try:
        with Hand.from_ports({n: str(d.link) for n, d in zip(names, devs, strict=True)}) as hand:
            hand.tare(samples=2)
            hand.start()
            seen = {}
            for ff in hand.frames(timeout=1.0):
                seen.setdefault(ff.finger, ff.frame)
                if len(seen) == 4:
                    break
            assert set(seen) == set(names)
            assert all(f.counts == (0, 0, 0, 0) for f in seen.values())
            assert set(hand.latest()) == set(names)
            assert set(hand.status.values()) == {"connected"}
            hand.stop()
    finally:
        for d in devs:
            d.stop()


def test_one_16_channel_device_split(tmp_path):
    fw = VirtualFirmware(16, source=lambda t: tuple(range(16)))
    with PtyDevice(fw, link=tmp_path / "hand16") as dev:
        ft = Fingertip(str(dev.link))
        groups = {"thumb": [0, 1, 2, 3], "index": [4, 5, 6, 7], "middle": [8, 9, 10, 11],
                  "ring": [12, 13, 14, 15]}
        fw.dead_mask = 1 << 9
        with Hand.split(ft, groups) as hand:
            hand.start()
            got = {}
            for ff in hand.frames(timeout=1.0):
                got[ff.finger] = ff.frame
                if len(got) == 4:
                    break
            assert got["index"].counts == (4, 5, 6, 7)
            assert got["middle"].counts == (8, 0, 10, 11)
            assert got["middle"].timeout_mask == 0b0010 and got["ring"].timeout_mask == 0


def test_empty_hand_is_refused():
    with pytest.raises(ValueError):
        Hand({})
