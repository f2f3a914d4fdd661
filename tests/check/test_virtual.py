"""`fingertip check` on virtual units behind a real pty: every build fault is found and
named; clean units with their normal spread raise no failure; the CLI's exits and report."""
from __future__ import annotations

import json
import subprocess
import sys
import time

import pytest

from fingertip.check import run_check
from fingertip.check.guide import NoPromptGuide
from fingertip.check.probe import DeviceProbe
from fingertip.device import Fingertip
from fingertip.sim.device.bringup import SimAudio, SimGuide, VirtualUnit
from fingertip.sim.device.faults import FAULTS, parse_fault, parse_faults
from fingertip.sim.device.pty_device import PtyDevice

from .lagging import LaggingProbe

SPEED = 4.0
"""Device seconds per wall second: the check's 15 s in about 4 s (faster starves the
virtual device on a loaded 2-core machine)."""
CLEAN_UNITS = 50
UNITS_PER_TEST = 5
"""The clean units in tests of five, which the test workers run side by side."""


def check_unit(seed: int, faults=(), prompt: bool = True, speed: float = SPEED):
    unit = VirtualUnit(seed, parse_faults(list(faults)))
    with PtyDevice(unit.firmware, speed=speed) as dev, \
            Fingertip(dev.port, command_timeout=2.0) as ft:
        guide = SimGuide(unit) if prompt else NoPromptGuide()
        return run_check(DeviceProbe(ft), guide, SimAudio(unit))


@pytest.mark.parametrize("fault", list(FAULTS))
def test_each_fault_is_found_and_named(fault):
    rep = check_unit(11, [fault])
    assert rep.faults == {fault}, rep.table()
    assert rep.exit_code() == 1


@pytest.mark.parametrize("spec", ["swapped-data:0,2", "swapped-data:1,3", "reversed-gauge:0",
                                  "loose-gauge:3", "missing-chip:0"])
def test_faults_on_other_channels(spec):
    rep = check_unit(5, [spec])
    f = parse_fault(spec)
    assert rep.faults == {f.name}, rep.table()
    named = {r.channel for r in rep.failures}
    assert set(f.channels) <= named


@pytest.mark.slow
@pytest.mark.parametrize("first", range(0, CLEAN_UNITS, UNITS_PER_TEST))
def test_no_false_failure_on_clean_units(first):
    failures = {}
    for seed in range(first, first + UNITS_PER_TEST):
        rep = check_unit(1000 + seed)
        if rep.failures:
            failures[seed] = [(r.check, r.channel, r.value) for r in rep.failures]
    assert not failures


class LateHostGuide(SimGuide):
    """The simulator acts as asked, then the host is busy elsewhere for 0.6 s (2.4 s of
    device time at SPEED): the whole press or the taps are queued before the check reads."""

    def press(self, face: int, label: str) -> bool:
        super().press(face, label)
        time.sleep(0.6)
        return True

    def tap(self, count: int) -> bool:
        super().tap(count)
        time.sleep(0.6)
        return True


def test_a_host_late_to_read_still_sees_the_presses_and_taps():
    # Beside busy loops a clean unit failed "press +X: no response": the capture dropped
    # the frames queued while the host was away, and the press with them.
    unit = VirtualUnit(1003)
    with PtyDevice(unit.firmware, speed=SPEED) as dev, \
            Fingertip(dev.port, command_timeout=2.0) as ft:
        rep = run_check(DeviceProbe(ft), LateHostGuide(unit), SimAudio(unit))
    assert not rep.failures, rep.table()
    assert rep.mapping is not None and not rep.skipped_steps


def test_a_device_behind_its_pace_still_shows_the_presses_and_taps():
    # Beside busy loops clean units failed "press -X: no response" while the capture went
    # by the frames' clock-mapped host times: a lagging simulator makes the press after it
    # was asked, but stamps it on its own late clock, which maps to before the request. The
    # simulator's own clock says where the step begins.
    unit = VirtualUnit(1012)
    with PtyDevice(unit.firmware, speed=SPEED) as dev, \
            Fingertip(dev.port, command_timeout=2.0) as ft:
        probe = LaggingProbe(ft, dev.held, 2.0 / SPEED, 1.6 / SPEED)
        rep = run_check(probe, SimGuide(unit), SimAudio(unit))
    assert probe.lags == 5
    assert not rep.failures, rep.table()
    assert rep.mapping is not None and not rep.skipped_steps


def test_no_prompt_skips_and_says_so():
    rep = check_unit(2, prompt=False)
    assert rep.ok
    assert len(rep.skipped_steps) == 5
    assert any(s.startswith("press +X") for s in rep.skipped_steps)
    assert rep.mapping is None


def test_fault_names_parse():
    assert parse_fault("swapped-data").channels == (0, 1)
    assert parse_fault("piezo-humming").piezo
    for bad in ("nope", "swapped-data:1", "reversed-gauge:9", "piezo-clipping:1",
                "loose-gauge:x"):
        with pytest.raises(ValueError):
            parse_fault(bad)


def run_cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "fingertip.cli", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=120)


def test_cli_fault_exit_table_and_json(tmp_path):
    r = run_cli("check", "--virtual", "--fault", "reversed-gauge", "--speed", str(SPEED),
                "--report", "r.json", "-q", cwd=tmp_path)
    assert r.returncode == 1, r.stderr
    assert "FAIL polarity ch2: channel 2 is reversed" in r.stdout
    d = json.loads((tmp_path / "r.json").read_text())
    assert d["faults"] == ["reversed-gauge"] and d["mapping"]["sign"] == [1, 1, -1, 1]
    assert d["device"]["virtual"]["faults"] == ["reversed-gauge"]


def test_cli_no_prompt_and_bad_input(tmp_path):
    r = run_cli("check", "--virtual", "--no-prompt", "--speed", str(SPEED), "--json", "-q",
                cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["skipped_steps"]
    r = run_cli("check", "--virtual", "--fault", "bogus", cwd=tmp_path)
    assert r.returncode == 2 and "unknown fault 'bogus'" in r.stderr
    r = run_cli("check", "--port", str(tmp_path / "nothing"), "--fault", "open-bridge",
                cwd=tmp_path)
    assert r.returncode == 2 and "--fault needs --virtual" in r.stderr
    r = run_cli("check", "--port", str(tmp_path / "nothing"), cwd=tmp_path)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1
    r = run_cli("sim", "faults", cwd=tmp_path)
    assert r.returncode == 0 and "stuck-dout" in r.stdout


def test_cli_hand_checks_each_fingertip(tmp_path):
    a, b = VirtualUnit(3), VirtualUnit(4, parse_faults(["missing-chip"]))
    with PtyDevice(a.firmware, speed=SPEED) as da, PtyDevice(b.firmware, speed=SPEED) as db:
        r = run_cli("check", "--port", da.port, "--port", db.port, "--no-prompt", "--no-audio",
                    "--report", "hand.json", "-q", cwd=tmp_path)
    assert r.returncode == 1, r.stderr
    d = json.loads((tmp_path / "hand.json").read_text())
    assert [f["ok"] for f in d["fingertips"]] == [True, False]
    assert d["fingertips"][1]["faults"] == ["missing-chip"]
    assert r.stdout.count("== /dev/") == 2


def test_cli_real_port_without_a_paired_sound_card_skips_the_piezo(tmp_path):
    """A port that is not a USB serial port here (a pty) pairs with no sound card: the
    check runs without the piezo and says why, naming check's own option for the card."""
    unit = VirtualUnit(5)
    with PtyDevice(unit.firmware, speed=SPEED) as dev:
        r = run_cli("check", "--port", dev.port, "--no-prompt", "--report", "r.json", "-q",
                    cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    warn = [line for line in r.stderr.splitlines() if "piezo not checked" in line]
    assert len(warn) == 1 and "not a USB serial port here" in warn[0], r.stderr
    assert warn[0].endswith("give the sound card with --audio-device"), warn[0]
