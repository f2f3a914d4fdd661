"""A timestamped CSV from any reference sensor: ``time`` (seconds, any clock) and ``fx``,
``fy`` (newtons; ``fz`` optional). Header names are matched without case; ``t``,
``time_s``, ``timestamp`` and ``fx_n``... are accepted."""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from .samples import ReferenceError, ReferenceSamples

TIME_NAMES = ("time", "time_s", "t", "timestamp", "unix_time", "host_time")
AXES = {"fx": ("fx", "fx_n", "force_x"), "fy": ("fy", "fy_n", "force_y"),
        "fz": ("fz", "fz_n", "force_z")}


class ReferenceFormatError(ReferenceError):
    """The CSV is not a usable reference: wrong columns, unsorted or non-numeric times."""


def _col(head: list[str], names: tuple[str, ...]) -> int | None:
    low = [h.strip().lower() for h in head]
    return next((low.index(n) for n in names if n in low), None)


def load_reference_csv(path: str | Path) -> ReferenceSamples:
    p = Path(path)
    try:
        with p.open(newline="", encoding="utf-8") as fh:
            rows = list(csv.reader(fh))
    except OSError as e:
        raise ReferenceFormatError(f"cannot read {p}: {e.strerror or e}") from None
    except UnicodeDecodeError:
        raise ReferenceFormatError(f"{p} is not a text CSV file") from None
    if not rows:
        raise ReferenceFormatError(f"{p} is empty")
    head = rows[0]
    it = _col(head, TIME_NAMES)
    idx = {k: _col(head, v) for k, v in AXES.items()}
    missing = [n for n, i in (("time", it), ("fx", idx["fx"]), ("fy", idx["fy"])) if i is None]
    if missing:
        raise ReferenceFormatError(
            f"{p}: no column for {', '.join(missing)} (have: {', '.join(head)}); need time "
            "(seconds) and fx, fy (newtons)")
    cols = [it, idx["fx"], idx["fy"]] + ([idx["fz"]] if idx["fz"] is not None else [])
    data = np.empty((len(rows) - 1, len(cols)))
    for k, row in enumerate(rows[1:]):
        try:
            data[k] = [float(row[c]) for c in cols]
        except (ValueError, IndexError):
            raise ReferenceFormatError(f"{p} line {k + 2}: not a number in the time or force "
                                       "columns (or a short row)") from None
    if not np.isfinite(data).all():
        bad = int(np.flatnonzero(~np.isfinite(data).all(axis=1))[0])
        raise ReferenceFormatError(f"{p} line {bad + 2}: NaN or infinite value")
    t = data[:, 0]
    back = np.flatnonzero(np.diff(t) <= 0)
    if len(back):
        k = int(back[0])
        raise ReferenceFormatError(
            f"{p} line {k + 3}: times must increase (time {t[k + 1]!r} after {t[k]!r}); "
            "sort the file by time and remove duplicates")
    force = np.zeros((len(t), 3))
    force[:, :data.shape[1] - 1] = data[:, 1:]
    return ReferenceSamples(t, force, None, str(p), {"rows": len(t)})
