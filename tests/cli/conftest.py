"""Fixtures of the command-line suite: a virtual fingertip on a pty."""
from __future__ import annotations

from collections.abc import Iterator

import pytest

from fingertip.sim import VirtualFirmware
from fingertip.sim.device.pty_device import PtyDevice
from tests.record.conftest import counts_source


@pytest.fixture
def device(tmp_path) -> Iterator[PtyDevice]:
    """A virtual fingertip on a pty whose counts change every frame."""
    with PtyDevice(VirtualFirmware(4, source=counts_source), link=tmp_path / "ttyFT0") as dev:
        yield dev
