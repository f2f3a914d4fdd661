"""Fixtures for the firmware-in-the-loop tests: the real ELF in simavr on a private pty."""
from __future__ import annotations

import os
from pathlib import Path

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
    pids: set[int] = set()

    def start(channels: int = 4, build: int | str | None = None, **kw) -> FirmwareSim:
        build = channels if build is None else build
        _need_builds(build)
        before = set(harnesses_running())
        sim = FirmwareSim(channels, firmware_elf(build), **kw).start()
        pids.update(set(harnesses_running()) - before)
        sims.append(sim)
        return sim

    yield start
    for sim in sims:
        sim.close()
    left = pids & set(harnesses_running())
    assert not left, f"harness processes left running: {sorted(left)}"


def harnesses_running() -> list[int]:
    """This process's children that run the simavr harness (an exited one has no exe link)."""
    exe = str(harness_binary().resolve())
    pids = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            ppid = int((d / "stat").read_text().rsplit(")", 1)[1].split()[1])
            if ppid == os.getpid() and os.readlink(d / "exe") == exe:
                pids.append(int(d.name))
        except (OSError, IndexError, ValueError):
            continue  # gone meanwhile, or not ours to read
    return pids
