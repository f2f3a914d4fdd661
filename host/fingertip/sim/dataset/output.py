"""The dataset's output folder: refusing a folder in use, replacing one this command
wrote, its ``dataset.json``, one-line progress, and the checks of the arguments."""
from __future__ import annotations

import hashlib
import json
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from ...badfile import check_input
from ...errors import Error
from ...outputs import atomic_output, writable_folder
from ..physics import (
    load,
    params_path,
)

GENERATOR = "fingertip sim dataset"
META_FILE = "dataset.json"


class DatasetError(Error, RuntimeError):
    """The dataset cannot be written. ``code`` (= ``exit_code``): 2 for a user error (bad
    argument, output folder not empty or not writable), 1 when writing failed part-way (disk
    full...)."""

    def __init__(self, message: str, code: int = 2) -> None:
        super().__init__(message, exit_code=code)
        self.code = code


# --- progress -----------------------------------------------------------------------------

class Progress:
    """A one-line progress report on stderr: rewritten in place on a terminal; otherwise a
    line at about every tenth of the work once it has run 2 s, and one at the end.
    ``enabled=False``: silent."""

    def __init__(self, total: int, label: str, stream: TextIO | None = None,
                 enabled: bool = True) -> None:
        self.total = max(1, total)
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.enabled = enabled
        self.done = 0
        self.t0 = time.monotonic()
        self._tty = enabled and bool(getattr(self.stream, "isatty", lambda: False)())
        self._last_decile = -1
        self._last_draw = 0.0

    def step(self, what: str = "") -> None:
        self.done += 1
        if not self.enabled:
            return
        now = time.monotonic()
        end = self.done >= self.total
        pct = 100 * self.done // self.total
        if self._tty:
            if end or now - self._last_draw >= 0.1:
                self._last_draw = now
                self.stream.write(f"\r{self.label}: {self.done}/{self.total} ({pct:3d} %) "
                                  f"{now - self.t0:5.1f} s  {what[-40:]:<40}")
                if end:
                    self.stream.write("\n")
                self.stream.flush()
        elif end or (pct // 10 > self._last_decile and now - self.t0 >= 2.0):
            self._last_decile = pct // 10
            self.stream.write(f"{self.label}: {self.done}/{self.total} ({pct} %) "
                              f"{now - self.t0:.1f} s\n")
            self.stream.flush()


# --- output folder ------------------------------------------------------------------------

def params_sha256(path: str | os.PathLike | None) -> str:
    data = (Path(path) if path is not None else params_path()).read_bytes()
    return hashlib.sha256(data).hexdigest()


def _ours(out: Path) -> dict[str, Any] | None:
    try:
        meta = json.loads((out / META_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return meta if isinstance(meta, dict) and meta.get("generator") == GENERATOR else None


def prepare_output(out: str | os.PathLike, force: bool = False) -> list[str]:
    """Make ``out`` ready for a new dataset; returns warnings.

    An existing non-empty folder is refused unless ``force``. With ``force``, the files of
    a dataset this command wrote there before (listed in its dataset.json) are removed
    first, so no stale class folder survives; anything else is left alone (and reported),
    never deleted.
    """
    out = Path(out)
    warnings: list[str] = []
    if out.exists() and not out.is_dir():
        raise DatasetError(f"{out} exists and is not a folder")
    if out.is_dir():
        try:
            entries = sorted(p.name for p in out.iterdir())
        except OSError as e:
            raise DatasetError(f"cannot read {out}: {e.strerror or e}") from e
        if entries and not force:
            raise DatasetError(
                f"{out} is not empty ({len(entries)} entries, e.g. {entries[0]!r}): choose a "
                f"new folder, or add --force to replace a dataset written there")
        if entries:
            meta = _ours(out)
            if meta is not None:
                _remove_dataset(out, meta)
            left = sorted(p.name for p in out.iterdir())
            if left:
                warnings.append(f"{out} holds {len(left)} entries this command did not write "
                                f"(left in place): {', '.join(left[:5])}"
                                + (" ..." if len(left) > 5 else ""))
    try:
        writable_folder(out)
    except OSError as e:
        raise DatasetError(f"cannot write into {out}: {e.strerror or e}") from e
    return warnings


def _remove_dataset(out: Path, meta: dict[str, Any]) -> None:
    root = out.resolve()
    dirs = set()
    for rel in [*meta.get("files", []), META_FILE]:
        p = (out / rel).resolve()
        if root not in p.parents:  # never outside the folder, whatever the file says
            continue
        try:
            p.unlink()
        except FileNotFoundError:
            pass
        except OSError as e:
            raise DatasetError(f"cannot remove {p} of the old dataset: {e.strerror or e}") \
                from e
        dirs.update(d for d in p.parents if root in d.parents)
    for d in sorted(dirs, key=lambda d: len(d.parts), reverse=True):
        try:
            d.rmdir()  # only if empty
        except OSError:
            pass


def write_meta(out: Path, meta: dict[str, Any]) -> None:
    """Write the dataset's description (dataset.json) atomically into ``out``."""
    with atomic_output(out / META_FILE) as tmp:
        tmp.write_text(json.dumps(meta, indent=1) + "\n", encoding="utf-8")


@dataclass
class DatasetResult:
    out: Path
    files: list[Path] = field(default_factory=list)
    """Every file written (relative to ``out``), dataset.json excluded."""
    meta: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    wall_s: float = 0.0


def check_int(name: str, value: int, lo: int, hi: int | None = None) -> int:
    """``value`` as an int in [lo, hi], or a :class:`DatasetError` naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise DatasetError(f"{name} must be an integer, not {value!r}")
    if value < lo or (hi is not None and value > hi):
        raise DatasetError(f"{name} must be " + (f"between {lo} and {hi}" if hi is not None
                                                 else f"at least {lo}") + f", not {value}")
    return int(value)


def load_params_file(params_file: str | os.PathLike | None):
    """The fingertip's parameters (the hardware's own when None) and the file they came from;
    a :class:`DatasetError` says why a file cannot be read."""
    if params_file is None:
        return load(), None
    try:
        check_input(params_file, "TOML parameter file")  # a FIFO would block for ever
        return load(params_file), str(params_file)
    except OSError as e:
        raise DatasetError(f"cannot read {params_file}: {e.strerror or e}") from e
    except ValueError as e:
        raise DatasetError(f"bad parameter file {params_file}: {e}") from e


def derived_seed(*parts: int) -> int:
    """A 31-bit seed drawn from ``parts``: one independent stream per recording."""
    return int(np.random.SeedSequence(list(parts)).generate_state(1)[0] & 0x7FFFFFFF)
