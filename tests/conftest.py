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
def port(tmp_path):
    """A virtual fingertip on a pty whose four channels read 1000, 2000, -3000 and 4: the
    path of its stable link."""
    from fingertip.sim import VirtualFirmware
    from fingertip.sim.device.pty_device import PtyDevice

    fw = VirtualFirmware(4, source=lambda t: (1000, 2000, -3000, 4))
    with PtyDevice(fw, link=tmp_path / "ft") as dev:
        yield str(dev.link)


@pytest.fixture
def tasks_cache(tmp_path_factory, monkeypatch) -> Path:
    """One cache of the simulated world's models (a force model per virtual unit, the shake
    MLP) for the session: the task tests and `fingertip experiment` train each once."""
    d = tmp_path_factory.getbasetemp() / "tasks-models"
    monkeypatch.setenv("FINGERTIP_TASKS_CACHE", str(d))
    return d


@pytest.fixture(scope="module")
def shake_clf(tmp_path_factory):
    """Today's world's shake classifier, trained once in the session's tasks cache."""
    from fingertip.models.vibration.classify import VibrationClassifier
    from fingertip.sim.world.boxes import shake_model_path

    mp = pytest.MonkeyPatch()
    mp.setenv("FINGERTIP_TASKS_CACHE", str(tmp_path_factory.getbasetemp() / "tasks-models"))
    try:
        yield VibrationClassifier(shake_model_path(), kind="shake")
    finally:
        mp.undo()


@pytest.fixture
def fil_builds() -> None:
    """Fail clearly when the simavr harness or the 4-channel firmware has not been built."""
    from fingertip.sim.device.simavr import HarnessError, firmware_elf, harness_binary

    try:
        harness_binary()
        firmware_elf(4)
    except HarnessError as e:
        pytest.fail(f"{e} (make test builds both before running pytest)")


# --- how pytest-xdist spreads the suite (make test: --dist loadgroup) ---------------------
_SHARED_SCOPES = {"module", "class", "package"}


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """A test that uses a fixture built once per module (or class, or package) joins its
    module's group, so the fixture is built once, on one worker; every other test is spread
    on its own, so one long module no longer holds a worker while the others wait. Runs
    before xdist's own hook, which reads the groups."""
    # On the workers xdist sets `dist` to "no" and keeps the choice in `loadgroup`.
    if not getattr(config.option, "loadgroup", False) and \
            config.getoption("dist", "no") != "loadgroup":
        return
    for item in items:
        info = getattr(item, "_fixtureinfo", None)  # pytest's, read by most xdist plugins
        defs = info.name2fixturedefs.values() if info is not None else None
        shared = defs is None or any(d[-1].scope in _SHARED_SCOPES for d in defs if d)
        if shared and item.get_closest_marker("xdist_group") is None:
            item.add_marker(pytest.mark.xdist_group(item.nodeid.split("::")[0]))


def pytest_collection_finish(session: pytest.Session) -> None:
    """xdist tells the controller a test's group by a suffix on its node id; pytest 9.2
    ignores that (pytest-xdist#1386), and the groups would be lost without a word: the
    module fixtures built on every worker, the suite far slower. Say so instead."""
    if not getattr(session.config.option, "loadgroup", False):
        return
    lost = [i.nodeid for i in session.items
            if i.get_closest_marker("xdist_group") and "@" not in i.nodeid]
    if lost:
        raise pytest.UsageError(f"pytest-xdist's loadgroup lost the group of {lost[0]} (and "
                                f"{len(lost) - 1} more): pytest {pytest.__version__} with "
                                "this xdist does not keep groups (pytest-xdist#1386); "
                                "requirements/dev.txt pins a pytest that does")
