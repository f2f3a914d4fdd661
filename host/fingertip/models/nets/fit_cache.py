"""Keys for fitted models kept on disk, so that a stale fit is never reused.

A model fitted once and cached (a virtual unit's force model, for instance) is valid only for
the code and parameters that made it. :func:`fit_key` hashes all of them: the caller's
parameters (any JSON-serialisable mapping), the text of every source and data file that
takes part in the fit (the caller names the files or folders: this module imports nothing of
the package's higher layers), the package's version and the versions of the libraries whose
numerics enter the fit. Change any one and the key, hence the cache folder, changes.
"""
from __future__ import annotations

import hashlib
import json
import logging
import sys
from collections.abc import Iterable, Mapping
from importlib import metadata
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)

SOURCE_SUFFIXES = (".py", ".toml", ".json", ".csv")
"""Files of a named folder that count as inputs of a fit (code and shipped parameters)."""
DEFAULT_LIBRARIES = ("numpy", "onnx", "onnxruntime")
"""Libraries whose versions enter every key: their numerics shape a fitted model."""
KEY_CHARS = 16


def _files(paths: Iterable[Path]) -> list[Path]:
    out: set[Path] = set()
    for p in paths:
        p = Path(p)
        if p.is_dir():
            out.update(q for q in p.rglob("*") if q.is_file() and q.suffix in SOURCE_SUFFIXES
                       and "__pycache__" not in q.parts)
        elif p.is_file():
            out.add(p)
        else:
            raise FileNotFoundError(f"fit input {p} does not exist")
    return sorted(out)


def _sources_digest(paths: tuple[Path, ...]) -> str:
    """Hash of the files' relative names and bytes (read each time, not memoised: a file
    edited while a process runs must change the key)."""
    h = hashlib.sha256()
    for f in _files(paths):
        # The name relative to its root folder, not the checkout's absolute path, so two
        # worktrees with identical sources share a key.
        root = next((Path(p) for p in paths if Path(p).is_dir() and
                     Path(p) in f.parents), f.parent)
        h.update(str(f.relative_to(root.parent)).encode() + b"\0")
        h.update(f.read_bytes() + b"\0")
    return h.hexdigest()


def library_versions(names: Iterable[str] = DEFAULT_LIBRARIES) -> dict[str, str]:
    """Installed version of each library (``"absent"`` when not installed)."""
    out = {}
    for n in names:
        try:
            out[n] = metadata.version(n)
        except metadata.PackageNotFoundError:
            out[n] = "absent"
    return out


def fit_key(params: Mapping[str, Any], sources: Iterable[Path | str], version: str,
            libraries: Iterable[str] = DEFAULT_LIBRARIES) -> str:
    """A short hex key of everything that determines a fit (see the module text).

    ``params`` must be JSON-serialisable (numbers, strings, lists, mappings); ``sources``
    are files or folders (every code or data file under a folder counts)."""
    try:
        p = json.dumps(dict(params), sort_keys=True, allow_nan=False)
    except (TypeError, ValueError) as e:
        raise ValueError(f"fit parameters are not plain JSON values: {e}") from None
    payload = {
        "params": p,
        "sources": _sources_digest(tuple(sorted(Path(s).resolve() for s in sources))),
        "version": version,
        "libraries": library_versions(libraries),
        "python": f"{sys.version_info.major}.{sys.version_info.minor}",
    }
    key = hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()[:KEY_CHARS]
    log.debug("fit key %s for %s", key, p)
    return key
