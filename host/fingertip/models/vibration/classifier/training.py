"""What training a classifier needs around the fit: windows of a whole dataset, stacking,
the split report, latency, and JSON-safe reports."""
from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from .datasets import Dataset, DatasetError
from .windows import FeaturePipeline, Windows


def json_safe(obj: object) -> object:
    """``obj`` with NaN and infinite floats replaced by None (strict JSON), numpy scalars
    and arrays as Python numbers and lists."""
    if isinstance(obj, dict):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return json_safe(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def require_test_set(test_idx: np.ndarray) -> None:
    if not len(test_idx):
        raise DatasetError("nothing to test on: every class has a single recording; the "
                           "evaluation is split by recording, so give some classes two or "
                           "more recordings")


def dataset_windows(ds: Dataset, pipe: FeaturePipeline,
                    progress: Callable[[int, int], None] | None = None
                    ) -> tuple[list[Windows], list[str]]:
    """Windows of every recording (a recording too short for one window has none: listed)."""
    out, short = [], []
    for i, it in enumerate(ds.items):
        w = pipe.windows(it.rec)
        if not len(w):
            short.append(ds.rel(it))
        out.append(w)
        if progress is not None:
            progress(i + 1, len(ds.items))
    return out, short


def stack(windows: list[Windows], labels: np.ndarray, rec_idx: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(inputs, labels, recording index) of the windows of recordings ``rec_idx``."""
    xs = [windows[i].inputs for i in rec_idx if len(windows[i])]
    if not xs:
        return np.zeros((0,)), np.zeros(0, np.int64), np.zeros(0, np.intp)
    ys = [np.full(len(windows[i]), labels[i]) for i in rec_idx if len(windows[i])]
    gs = [np.full(len(windows[i]), i) for i in rec_idx if len(windows[i])]
    return np.concatenate(xs), np.concatenate(ys), np.concatenate(gs)


def latency_ms(fn: Callable[[], object], repeats: int = 200, warmup: int = 10
               ) -> dict[str, float]:
    """Median and 90th percentile wall time of ``fn()`` in milliseconds."""
    for _ in range(warmup):
        fn()
    t = np.empty(repeats)
    for i in range(repeats):
        t0 = time.perf_counter()
        fn()
        t[i] = time.perf_counter() - t0
    return {"p50": float(np.median(t) * 1e3), "p90": float(np.percentile(t, 90) * 1e3)}


def split_report(ds: Dataset, train_idx: np.ndarray, test_idx: np.ndarray,
                 val_idx: np.ndarray | None = None) -> dict:
    per = {}
    fit = np.setdiff1d(train_idx, val_idx) if val_idx is not None else train_idx
    for c in ds.classes:
        per[c] = {"train": int(sum(ds.items[i].cls == c for i in fit)),
                  "test": int(sum(ds.items[i].cls == c for i in test_idx))}
        if val_idx is not None:
            per[c]["validation"] = int(sum(ds.items[i].cls == c for i in val_idx))
    out = {"by": "recording", "per_class": per,
           "test_recordings": [ds.rel(ds.items[i]) for i in test_idx]}
    if val_idx is not None:
        out["validation_recordings"] = [ds.rel(ds.items[i]) for i in val_idx]
    return out
