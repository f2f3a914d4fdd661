"""The virtual fingertip on a real pty that the device tests talk to."""
from __future__ import annotations

import pytest

from fingertip.sim import VirtualFirmware
from fingertip.sim.device.pty_device import PtyDevice


@pytest.fixture
def device(tmp_path):
    fw = VirtualFirmware(4, source=lambda t: (1000 + (t // 12500) % 7, -50_000, 0x7FFFFF, 5))
    with PtyDevice(fw, link=tmp_path / "ttyFT0") as dev:
        yield dev
