"""What every trainer checks first: the shapes agree, nothing is NaN or infinite, labels
name a class. One check, so that bad training data reads the same whichever model it meets."""
from __future__ import annotations

import numpy as np


def check_training(x: np.ndarray, y: np.ndarray, *, ndim: int = 2,
                   dtype: type = np.float64, classes: int | None = None,
                   shape: str = "(n, features)") -> tuple[np.ndarray, np.ndarray]:
    """``(x, y)`` as arrays (``x`` of ``dtype``), or a one-line ``ValueError``: ``x`` must
    have ``ndim`` dimensions (``shape`` describes them) and one target per row, at least one
    row, and only finite values. ``classes``: ``y`` holds integer labels 0..classes-1
    (int64); otherwise float targets must be finite too."""
    x = np.asarray(x, dtype)
    y = np.asarray(y, np.int64) if classes is not None else np.asarray(y)
    if x.ndim != ndim or len(x) != len(y) or not len(x):
        raise ValueError(f"need X of shape {shape} and one target per row, got {x.shape} "
                         f"and {y.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError("training inputs contain NaN or infinite values")
    if classes is not None:
        if y.min() < 0 or y.max() >= classes:
            raise ValueError("labels must be 0..classes-1")
    elif y.dtype.kind == "f" and not np.all(np.isfinite(y)):
        raise ValueError("training targets contain NaN or infinite values")
    return x, y
