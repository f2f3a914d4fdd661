"""The device library (the firmware's C++ built for the host) against the shared constants,
and its failure modes: no silent fallback, errors of the inputs handed back."""
from __future__ import annotations

import math
import subprocess
import sys

import pytest

from fingertip.protocol import Start, encode
from fingertip.protocol.messages import STATS_FIELDS
from fingertip.sim import FIRMWARE_VERSION, VirtualFirmware, device_lib
from tests.conftest import ROOT, load_vectors

C = load_vectors()["constants"]


def test_library_constants_match_the_shared_list():
    lib = device_lib.constants()
    scalars = {k: v for k, v in C.items() if isinstance(v, int)}
    assert {k: lib[k] for k in scalars} == scalars
    assert {k: lib[k] for k in C["message_types"]} == C["message_types"]
    assert {k: lib[k] for k in C["nack_errors"]} == C["nack_errors"]
    assert list(device_lib.stats_fields()) == C["stats_fields"] == list(STATS_FIELDS)
    assert FIRMWARE_VERSION == (lib["firmware_major"], lib["firmware_minor"],
                                lib["firmware_patch"])


def test_missing_library_is_a_loud_error(tmp_path):
    # A fresh process pointed at a library that does not exist: no Python fallback runs.
    code = ("from fingertip.sim import VirtualFirmware\n"
            "VirtualFirmware(4)\n")
    env = {"PYTHONPATH": str(ROOT / "host"), device_lib.ENV_VAR: str(tmp_path / "nope.so")}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert r.returncode != 0
    assert "DeviceLibraryError" in r.stderr and "make -C firmware hostlib" in r.stderr


def test_source_errors_reach_the_caller():
    def broken(t):
        raise KeyError("scene")

    fw = VirtualFirmware(4, source=broken)
    fw.boot()
    fw.receive(encode(Start(1)))
    with pytest.raises(KeyError, match="scene"):
        fw.advance(100_000)
    fw.source = lambda t: (math.nan, 0, 0, 0)
    with pytest.raises(ValueError, match="NaN"):
        fw.advance(200_000)
    fw.source = lambda t: (1, 2, 3, 4)
    assert fw.advance(300_000)  # the device runs on once the inputs are good


def test_source_is_called_only_when_the_chips_are_read():
    calls = []
    fw = VirtualFirmware(4, source=lambda t: calls.append(t) or (0, 0, 0, 0))
    fw.boot()
    fw.advance(1_000_000)
    # 80 SPS after 4 periods of settling: one read, and one call, per conversion.
    assert calls == list(range(50_000, 1_000_001, 12_500))
    fw.dead_mask = 0b1111
    n = len(calls)
    fw.advance(2_000_000)
    assert len(calls) == n  # no chip ready: nothing to ask for
    with pytest.raises(ValueError):
        fw.dead_mask = 0b10000


def test_counters_and_state_come_from_the_cpp_device():
    fw = VirtualFirmware(4, source=lambda t: (8_388_607, 0, 0, 0))
    fw.boot()
    fw.receive(encode(Start(1)))
    fw.advance(1_000_000)
    c = fw.counters
    assert list(c) == list(STATS_FIELDS[1:])
    # INFO and LOG at boot, the ACK, 77 samples from 50 ms on, the STATS at 1 s.
    assert c["saturations"] == 77 and c["frames_sent"] == 2 + 1 + 77 + 1
    assert c["longest_loop_us"] == 0  # the device is polled only when something is due
    assert (fw.streaming, fw.powered, fw.rate_sps, fw.gain, fw.flags) == (True, True, 80, 128, 1)
    fw.reset()
    assert not fw.streaming and fw.now_us == 0 and fw.next_due_us is None
