"""`fingertip check` against the real firmware in simavr with the build faults built into the
simulated HX711s (firmware/sim: swap, fault, chip, noise): each is found and named."""
from __future__ import annotations

from contextlib import contextmanager

import pytest

from fingertip.check import run_check
from fingertip.check.probe import DeviceProbe
from fingertip.sim.device.faults import FAULTS, PIEZO_FAULTS, parse_faults, simavr_commands
from fingertip.sim.device.simavr import open_fingertip
from fingertip.sim.device.simavr_check import SimavrGuide
from tests.check.lagging import LaggingProbe

REST = [100_000, -200_000, 30_000, 50_000]
NOISE = 45.0
STRAIN = [f for f in FAULTS if f not in PIEZO_FAULTS]
QUICK = {"", "swapped-data", "missing-chip"}


def check_with(make_sim, faults, probe):
    sim = make_sim(4, noise=NOISE, seed=3)
    for ch, v in enumerate(REST):
        sim.set(ch, v)
    for cmd in simavr_commands(parse_faults(faults), NOISE):
        sim.command(cmd)
    ft = open_fingertip(sim)
    try:
        return run_check(probe(ft, sim), SimavrGuide(sim, REST))
    finally:
        ft.close()


@pytest.mark.parametrize("fault", [
    pytest.param(f, marks=() if f in QUICK else pytest.mark.slow) for f in ["", *STRAIN]])
def test_fault_found_in_firmware(make_sim, fault):
    rep = check_with(make_sim, [fault] if fault else [], lambda ft, sim: DeviceProbe(ft))
    assert rep.faults == ({fault} if fault else set()), rep.table()
    assert not rep.warnings, rep.table()


def test_harness_rejects_bad_fault_commands(make_sim):
    from fingertip.sim.device.simavr import HarnessError

    sim = make_sim(4)
    with pytest.raises(HarnessError, match="bad fault"):
        sim.command("fault 1 melted")
    with pytest.raises(HarnessError, match="swap takes two channel numbers"):
        sim.command("swap * 1")
    sim.command("fault 2 reversed")
    sim.command("swap 0 3")
    chips = sim.chips()
    assert chips[2]["fault"] == "reversed" and chips[0]["route"] == 3


@contextmanager
def held(sim):
    sim.hold()
    try:
        yield
    finally:
        sim.go()


@pytest.mark.parametrize("fault", ["", "swapped-data"])
def test_a_firmware_behind_its_pace_is_checked_as_one_on_time(make_sim, fault):
    # simavr runs as fast as it can: on a busy host its clock stalls and runs on, and the
    # frames' clock-mapped host times say little about when the firmware made them (8 units
    # failed their presses beside busy loops when the capture went by them). The guide
    # records from the firmware's own clock at the request.
    probes = []

    def lagging(ft, sim):
        probes.append(LaggingProbe(ft, lambda: held(sim), 0.5, 0.4))
        return probes[-1]

    rep = check_with(make_sim, [fault] if fault else [], lagging)
    assert probes[0].lags == 4  # the presses (no taps: no piezo on the Uno)
    assert rep.faults == ({fault} if fault else set()), rep.table()
