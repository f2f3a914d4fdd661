"""Processes on loopback: discovery kept on this machine (no multicast needed)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.children import default_signals

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True)
def localhost_only(monkeypatch):
    """ROS 2's own switch: every participant of these tests stays on the loopback interface
    (and a test domain of its own, away from anything else on this machine)."""
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.delenv("CYCLONEDDS_URI", raising=False)
    monkeypatch.delenv("ROS_STATIC_PEERS", raising=False)
    monkeypatch.setenv("ROS_DOMAIN_ID", str(domain_id()))


def domain_id() -> int:
    """A DDS domain per test process: parallel workers (pytest-xdist's gw0 to gw2) and the
    serial realtime pass running beside them (as 3) get different ones for sure, separate runs
    on one machine most likely (by process id). Even numbers: a test may use its domain + 1 as
    one where nobody listens."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "gw3").removeprefix("gw")
    return 18 + (os.getpid() % 25) * 8 + 2 * (int(worker) % 4)


def env() -> dict[str, str]:
    e = dict(os.environ)
    # The test suite's force model (tests.record.conftest.force_model) must be importable.
    e["PYTHONPATH"] = os.pathsep.join([str(ROOT), e.get("PYTHONPATH", "")])
    return e


def cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "fingertip.cli", *args]


def start(*args: str) -> subprocess.Popen:
    return subprocess.Popen(cli(*args), env=env(), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=default_signals)


def wait_line(proc: subprocess.Popen, prefix: str, max_lines: int = 50) -> None:
    """Read ``proc``'s stderr up to the line starting with ``prefix`` (libraries may log
    before it); fail if the process ends first."""
    for _ in range(max_lines):
        line = proc.stderr.readline()
        if not line:
            raise AssertionError(f"the process ended before printing {prefix!r}")
        if line.startswith(prefix):
            return
    raise AssertionError(f"no line starting with {prefix!r}")
