"""Hand: fingers on separate devices, or one 16-channel device split into fingers."""
from __future__ import annotations

import time

import pytest

from fingertip import Fingertip, Hand
from fingertip.sim import VirtualFirmware
from fingertip.sim.device.pty_device import PtyDevice


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


def test_finger_views_of_a_split_device(tmp_path):
    """FingerView: each finger's frames hold its channels only; the shared device gets one
    Start and stops with the last finger; a tare touches the finger's channels only."""
    from fingertip.device.finger import finger_views

    fw = VirtualFirmware(16, source=lambda t: tuple(1000 * (c + 1) for c in range(16)))
    with PtyDevice(fw, link=tmp_path / "hand16") as dev:
        groups = {"thumb": range(0, 4), "index": range(4, 8), "middle": range(8, 12),
                  "ring": range(12, 16)}
        with Hand.split(Fingertip(str(dev.link)), groups) as hand:
            views = finger_views(hand)
            assert [v.name for v in views] == list(groups)
            assert all(v.channels == 4 for v in views)
            assert views[1].settings.device_channels == [4, 5, 6, 7]
            got: dict[str, list] = {v.name: [] for v in views}
            for v in views:
                v.add_callback(got[v.name].append)
                v.start()
            assert fw.streaming
            deadline = time.monotonic() + 5.0
            while min(len(x) for x in got.values()) < 3 and time.monotonic() < deadline:
                time.sleep(0.05)
            assert got["index"][0].counts == (5000, 6000, 7000, 8000)
            assert got["ring"][0].counts == (13000, 14000, 15000, 16000)
            offsets = views[2].tare(samples=2)   # middle: device channels 8..11
            assert offsets == (9000, 10000, 11000, 12000)
            assert tuple(hand.device("ring").get_info().tare_offsets[:16]) == \
                (0,) * 8 + (9000, 10000, 11000, 12000) + (0,) * 4
            for v in views[:3]:
                v.stop()
            assert fw.streaming      # the ring finger still streams
            views[3].stop()
            assert not fw.streaming
            views[0].remove_callback(got["thumb"].append)
            with pytest.raises(ValueError):
                views[0].remove_callback(got["thumb"].append)
