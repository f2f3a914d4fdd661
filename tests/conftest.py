"""Shared fixtures for every suite."""
from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

# Shared, noisy machines: no per-example deadline; in CI, the same examples on every run.
settings.register_profile("default", deadline=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("ci", parent=settings.get_profile("default"), derandomize=True,
                          print_blob=True)
settings.load_profile("ci" if os.environ.get("CI") else "default")

ROOT = Path(__file__).resolve().parent.parent
VECTORS_FILE = ROOT / "tests" / "vectors" / "protocol_v1.json"


def load_vectors() -> dict:
    data = json.loads(VECTORS_FILE.read_text(encoding="utf-8"))
    # A vector file that lost its entries must fail loudly, not pass vacuously.
    for key in ("crc", "cobs", "frames", "invalid", "streams"):
        assert data.get(key), f"{VECTORS_FILE} has no {key!r} vectors"
    return data


@pytest.fixture(scope="session")
def vectors() -> dict:
    return load_vectors()


@pytest.fixture
def tasks_cache(tmp_path_factory, monkeypatch) -> Path:
    """One cache of the simulated world's models (a force model per virtual unit, the shake
    MLP) for the session: the task tests and `fingertip experiment` train each once."""
    d = tmp_path_factory.getbasetemp() / "tasks-models"
    monkeypatch.setenv("FINGERTIP_TASKS_CACHE", str(d))
    return d


@pytest.fixture
def fil_builds() -> None:
    """Fail clearly when the simavr harness or the 4-channel firmware has not been built."""
    from fingertip.sim.device.simavr import HarnessError, firmware_elf, harness_binary

    try:
        harness_binary()
        firmware_elf(4)
    except HarnessError as e:
        pytest.fail(f"{e} (make test builds both before running pytest)")
