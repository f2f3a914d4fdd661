"""One decision from many window predictions."""
from __future__ import annotations

import numpy as np


def majority_vote(probabilities: np.ndarray) -> int:
    """The class predicted most often over windows (ties: the higher summed probability)."""
    p = np.asarray(probabilities)
    if p.ndim != 2 or not len(p):
        raise ValueError("need a (windows, classes) array with at least one window")
    votes = np.bincount(p.argmax(axis=1), minlength=p.shape[1]).astype(float)
    votes += 1e-6 * p.sum(axis=0) / len(p)  # tie-break, never outweighs one vote
    return int(np.argmax(votes))
