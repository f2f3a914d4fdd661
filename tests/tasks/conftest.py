"""One model cache for every task test (force models per virtual unit, the shake MLP)."""
from __future__ import annotations

import pytest


@pytest.fixture(autouse=True)
def _cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("FINGERTIP_TASKS_CACHE",
                       str(tmp_path_factory.getbasetemp() / "tasks-models"))
