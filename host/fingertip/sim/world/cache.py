"""The on-disk cache of what the simulated world trains once and reuses (force models of
virtual units, the shake classifier).

One lock serialises builders across threads of a process; a build goes to a temporary folder
and is renamed into place only when complete, so a crash never leaves a half-written entry.
"""
from __future__ import annotations

import os
import shutil
import tempfile
import threading
from collections.abc import Callable
from pathlib import Path

_lock = threading.Lock()


def cache_dir() -> Path:
    """Where fitted per-unit force models are kept (``FINGERTIP_TASKS_CACHE`` overrides)."""
    d = os.environ.get("FINGERTIP_TASKS_CACHE")
    return Path(d) if d else Path(tempfile.gettempdir()) / "fingertip-tasks-models"


def cached(name: str, product: str, build: Callable[[Path], None]) -> Path:
    """``cache_dir()/name/product``, calling ``build(folder)`` once to fill ``name`` if absent.

    ``build`` writes into a fresh temporary folder under the cache; that folder replaces any
    stale ``name`` entry in one rename."""
    out = cache_dir() / name
    path = out / product
    with _lock:
        if not path.is_file():
            cache_dir().mkdir(parents=True, exist_ok=True)
            tmp = Path(tempfile.mkdtemp(prefix=f"{name}-", dir=cache_dir()))
            build(tmp)
            if out.exists():
                shutil.rmtree(out)
            os.replace(tmp, out)
        return path
