"""One model cache for every task test (force models per virtual unit, the shake MLP)."""
from __future__ import annotations

import pytest


@pytest.fixture(autouse=True)
def _cache(tasks_cache):
    return tasks_cache
