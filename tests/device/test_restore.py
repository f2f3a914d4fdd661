"""Taking a device back after a reconnect or a reset: its set-up is restored, and a
reconnect by path must not hand out another device's frames: when something else
answers on the port (here a 16-channel virtual fingertip taking the link of a 4-channel
one), its frames are dropped and counted, and the right device is taken back when it
returns."""
from __future__ import annotations

import time

import pytest

from fingertip import Fingertip
from fingertip.protocol import Start, encode
from fingertip.sim import VirtualFirmware
from fingertip.sim.device.pty_device import PtyDevice

from .waiting import PATIENCE, wait_for


def test_a_foreign_device_on_the_path_is_refused(tmp_path):
    link = tmp_path / "tty"
    first = PtyDevice(VirtualFirmware(4), link=link).start()
    ft = Fingertip(str(link)).open()
    got = []
    ft.add_callback(got.append)
    try:
        ft.start()
        assert wait_for(lambda: len(got) >= 5, PATIENCE)
        first.stop()  # unplugged; something else takes the path
        with PtyDevice(VirtualFirmware(16), link=link):
            # It streams without being asked by this host: someone else started it.
            with open(link, "wb", buffering=0) as port:
                port.write(encode(Start(1)))
            assert wait_for(lambda: ft.stats.foreign_devices >= 1, PATIENCE)
            n = len(got)
            time.sleep(0.5)
            assert all(len(f.counts) == 4 for f in got)  # not one 16-channel frame
            assert len(got) == n, [(len(f.counts), f.seq, f.device_time_us) for f in got[n - 3:]]
        back = PtyDevice(VirtualFirmware(4), link=link).start()  # the right one returns
        try:
            assert wait_for(lambda: len(got) >= n + 10, PATIENCE), ft.stats
            assert all(len(f.counts) == 4 for f in got)
            assert ft.status == "connected"
        finally:
            back.stop()
    finally:
        ft.close()
        first.stop()


def test_the_same_device_comes_back_with_its_frames(tmp_path):
    link = tmp_path / "tty"
    with PtyDevice(VirtualFirmware(4), link=link) as dev, Fingertip(str(link)) as ft:
        ft.start()
        assert ft.read(timeout=2) is not None
        dev.replug(reboot=False)  # a glitch: the same device keeps streaming
        assert wait_for(lambda: ft.stats.reconnects >= 1, PATIENCE)
        ft.drain()
        assert ft.read(timeout=3) is not None
        assert ft.stats.foreign_devices == 0


@pytest.mark.realtime
def test_reconnect_after_unplug_restores_the_setup(device):
    with Fingertip(str(device.link)) as ft:
        ft.set_rate(80, 2)
        ft.set_gain(64)
        offsets = ft.tare(samples=4)
        ft.start()
        assert ft.read(timeout=1.0) is not None
        device.unplug()
        assert wait_for(lambda: ft.status == "reconnecting", 2.0)
        time.sleep(0.3)
        t0 = time.monotonic()
        device.replug(reboot=True)  # a new pty, and the device forgot everything
        assert wait_for(lambda: ft.status == "connected", 1.0)
        assert time.monotonic() - t0 < 1.0
        assert wait_for(lambda: device.firmware.streaming, 2.0)
        fw = device.firmware
        assert (fw.decimation, fw.gain) == (2, 64)
        assert tuple(fw.offsets) == offsets
        ft.drain()
        f = ft.read(timeout=1.0)
        assert f is not None and f.counts[1] == -50_000 // 2 - offsets[1]
        assert ft.stats.reconnects == 1


def test_device_reset_mid_stream_is_counted_and_repaired(device):
    with Fingertip(str(device.link)) as ft:
        ft.start()
        assert ft.read(timeout=1.0) is not None
        device.reset()
        assert wait_for(lambda: ft.stats.device_resets == 1, PATIENCE)
        assert wait_for(lambda: device.firmware.streaming, PATIENCE)
        ft.drain()
        assert ft.read(timeout=1.0) is not None
        assert ft.stats.reconnects == 0
