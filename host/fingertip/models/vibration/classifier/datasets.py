"""Labelled folders of vibration recordings (one sub-folder per class) and their splits **by
recording**: every window of a recording is on the same side, train or test, and each class
contributes test recordings in proportion (stratified)."""
from __future__ import annotations

import logging
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ....audio.sanity import signal_problem
from ....errors import BadFileError
from ..features import (
    AUDIO_EXTENSIONS,
    CSV_EXTENSIONS,
    FeatureError,
    NonFiniteSamples,
    Recording,
    read_recording,
)

log = logging.getLogger(__name__)


class DatasetError(BadFileError):
    """A training folder that cannot be used (layout, too few recordings, unreadable, a
    silent, constant, non-finite or clipped recording): a
    :class:`~fingertip.errors.BadFileError`, so a ValueError; exit status 2."""


@dataclass
class Labelled:
    path: Path
    cls: str
    label: int
    rec: Recording


@dataclass
class Dataset:
    folder: Path
    classes: list[str]
    items: list[Labelled]
    skipped: list[str] = field(default_factory=list)

    @property
    def labels(self) -> np.ndarray:
        return np.array([it.label for it in self.items], dtype=np.int64)

    @property
    def rates(self) -> list[float]:
        return sorted({it.rec.rate for it in self.items})

    def counts(self) -> dict[str, int]:
        return {c: sum(1 for it in self.items if it.cls == c) for c in self.classes}

    def rel(self, it: Labelled) -> str:
        try:
            return str(it.path.relative_to(self.folder))
        except ValueError:
            return str(it.path)


def scan_folder(folder: str | os.PathLike) -> tuple[list[str], list[tuple[Path, str]]]:
    """(classes, [(file, class)]) of a folder with one sub-folder per class (files found
    recursively inside each; hidden files and other extensions ignored)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise DatasetError(f"{folder}: not a folder (expected one sub-folder per class)")
    exts = AUDIO_EXTENSIONS + CSV_EXTENSIONS
    classes, files = [], []
    for sub in sorted(p for p in folder.iterdir() if p.is_dir() and not p.name.startswith(".")):
        found = sorted(p for p in sub.rglob("*") if p.is_file() and p.suffix.lower() in exts
                       and not any(part.startswith(".") for part in p.relative_to(sub).parts))
        if found:
            classes.append(sub.name)
            files += [(p, sub.name) for p in found]
    if len(classes) < 2:
        raise DatasetError(f"{folder}: found {len(classes)} class folder(s) with recordings "
                           f"({', '.join(classes) or 'none'}); need at least 2 sub-folders, "
                           f"one per class, holding {'/'.join(exts)} files")
    return classes, files


def load_folder(folder: str | os.PathLike, *, rate_hint: float | None = None,
                channel: int = 0, skip_bad: bool = True,
                progress: Callable[[int, int], None] | None = None) -> Dataset:
    """Read every recording of a class-per-sub-folder dataset.

    ``rate_hint``: the sample rate of CSV files that do not state theirs. Unreadable files
    are skipped with a warning when ``skip_bad``, else raise; a silent, constant,
    NaN/Inf or clipped recording (:func:`~fingertip.audio.sanity.signal_problem`) is refused
    with a DatasetError naming it.
    """
    folder = Path(folder)
    classes, files = scan_folder(folder)
    items, skipped = [], []
    for i, (path, cls) in enumerate(files):
        try:
            rec = read_recording(path, rate_hint, channel)
        except NonFiniteSamples as e:
            raise DatasetError(f"{e}; refused for training: remove it from the folder") from e
        except FeatureError as e:
            if not skip_bad:
                raise
            log.warning("skipped: %s", e)
            skipped.append(f"{path}: {e}")
            continue
        if (problem := signal_problem(rec.samples, rec.full_scale)) is not None:
            raise DatasetError(f"{path}: {problem}: refused for training (remove it from the "
                               "folder or record it again)")
        if rec.clipped:
            log.warning("%s: %.2f %% of the samples look clipped", path,
                        100 * rec.clipped_fraction)
        items.append(Labelled(path, cls, classes.index(cls), rec))
        if progress is not None:
            progress(i + 1, len(files))
    present = [c for c in classes if any(it.cls == c for it in items)]
    if len(present) < 2:
        raise DatasetError(f"{folder}: fewer than two classes have readable recordings")
    if present != classes:
        items = [Labelled(it.path, it.cls, present.index(it.cls), it.rec) for it in items]
    return Dataset(folder, present, items, skipped)


def split_by_recording(labels: Sequence[int], test_fraction: float = 0.25, seed: int = 0
                       ) -> tuple[np.ndarray, np.ndarray]:
    """(train, test) indices of recordings, stratified by class: each class with two or
    more recordings puts ``round(n * test_fraction)`` of them (at least one, at most n - 1)
    on the test side. A class with a single recording stays in training (warned)."""
    if not 0 < test_fraction < 1:
        raise ValueError("test_fraction must be between 0 and 1")
    labels = np.asarray(labels)
    rng = np.random.default_rng(seed)
    test = []
    for c in np.unique(labels):
        idx = np.flatnonzero(labels == c)
        if len(idx) < 2:
            log.warning("class %s has one recording: it cannot be tested (train only)", c)
            continue
        k = min(len(idx) - 1, max(1, int(round(len(idx) * test_fraction))))
        test += rng.permutation(idx)[:k].tolist()
    test_idx = np.array(sorted(test), dtype=np.intp)
    train_idx = np.setdiff1d(np.arange(len(labels)), test_idx)
    return train_idx, test_idx


def stratified_folds(labels: Sequence[int], k: int, seed: int = 0) -> list[np.ndarray]:
    """``k`` disjoint test sets of recordings covering every recording once, each class
    spread evenly over the folds (cross-validation by recording)."""
    if k < 2:
        raise ValueError("cross-validation needs 2 or more folds")
    labels = np.asarray(labels)
    rng = np.random.default_rng(seed)
    fold_of = np.empty(len(labels), dtype=np.intp)
    offset = 0
    for c in np.unique(labels):
        idx = rng.permutation(np.flatnonzero(labels == c))
        if len(idx) < k:
            raise DatasetError(f"{k}-fold cross-validation needs {k} or more recordings per "
                               f"class; class {c} has {len(idx)}")
        fold_of[idx] = (np.arange(len(idx)) + offset) % k
        offset += len(idx)  # classes with few recordings do not all start at fold 0
    return [np.flatnonzero(fold_of == f) for f in range(k)]


def validation_split(labels: Sequence[int], pool: np.ndarray, seed: int = 0,
                     fraction: float = 0.15) -> tuple[np.ndarray, np.ndarray]:
    """Hold ``fraction`` of each class's training recordings ``pool`` out (at least one,
    for classes with three or more there) for early stopping. Returns (fit, validation)."""
    labels = np.asarray(labels)
    rng = np.random.default_rng(seed + 1)
    val: list[int] = []
    for c in np.unique(labels[pool]):
        idx = pool[labels[pool] == c]
        if len(idx) >= 3:
            k = min(len(idx) - 2, max(1, int(round(fraction * len(idx)))))
            val += rng.permutation(idx)[:k].tolist()
    val_idx = np.array(sorted(val), dtype=np.intp)
    return np.setdiff1d(pool, val_idx), val_idx


def dataset_summary(ds: Dataset) -> dict:
    return {"folder": str(ds.folder), "classes": ds.classes, "recordings": ds.counts(),
            "rates_hz": ds.rates, "skipped": ds.skipped,
            "clipped_recordings": [ds.rel(it) for it in ds.items if it.rec.clipped],
            "seconds": round(sum(it.rec.duration for it in ds.items), 3)}
