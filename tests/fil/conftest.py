"""Fixtures for the firmware-in-the-loop tests: the real ELF in simavr on a private pty."""
from __future__ import annotations

import pytest

from fingertip.sim.device.simavr import FirmwareSim, HarnessError, firmware_elf, harness_binary


def _need_builds(channels: int | str) -> None:
    try:
        harness_binary()
        firmware_elf(channels)
    except HarnessError as e:
        pytest.fail(f"{e} (make test builds both before running pytest)")


@pytest.fixture
def make_sim():
    """Start harnesses on demand; every one is quit (and checked gone) at teardown."""
    sims: list[FirmwareSim] = []

    def start(channels: int = 4, build: int | str | None = None, **kw) -> FirmwareSim:
        build = channels if build is None else build
        _need_builds(build)
        sim = FirmwareSim(channels, firmware_elf(build), **kw).start()
        sims.append(sim)
        return sim

    yield start
    for sim in sims:
        proc = sim._proc
        sim.close()
        assert proc is None or proc.poll() is not None, "harness left running"
