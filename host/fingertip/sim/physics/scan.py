"""Vectorised recurrences: prefix scans for first-order filters and play operators.

Creep (x[t] = a[t] x[t-1] + b[t]) and hysteresis (p[t] = clip(p[t-1], u[t] - r, u[t] + r))
are recurrences, which a Python loop would evaluate one sample at a time. Both step maps are
closed under composition (affine maps; clamps), so the prefix compositions come out of a
Hillis-Steele scan: ceil(log2 N) whole-array numpy passes, exact, for any N and any shape.
"""
from __future__ import annotations

import numpy as np


def affine_scan(a: np.ndarray, b: np.ndarray, x0: np.ndarray | float) -> np.ndarray:
    """x[t] = a[t] * x[t-1] + b[t] along axis 0, with x[-1] = x0."""
    a = np.array(a, dtype=float, copy=True)
    b = np.array(b, dtype=float, copy=True)
    n = a.shape[0]
    s = 1
    while s < n:
        # Compose step t with the prefix ending at t - s: (a2, b2) o (a1, b1).
        b[s:] = a[s:] * b[:-s] + b[s:]
        a[s:] = a[s:] * a[:-s]
        s *= 2
    return a * x0 + b


def play_scan(u: np.ndarray, r: np.ndarray | float, p0: np.ndarray | float) -> np.ndarray:
    """Play (backlash) operator p[t] = clip(p[t-1], u[t] - r, u[t] + r) along axis 0.

    Each step is a clamp to [lo, hi]; clamp2 o clamp1 is the clamp to
    [clip(lo1, lo2, hi2), clip(hi1, lo2, hi2)], which makes the prefix scan possible.
    """
    u = np.asarray(u, dtype=float)
    lo = u - r
    hi = u + r
    n = u.shape[0]
    s = 1
    while s < n:
        new_lo = np.clip(lo[:-s], lo[s:], hi[s:])
        hi[s:] = np.clip(hi[:-s], lo[s:], hi[s:])
        lo[s:] = new_lo
        s *= 2
    return np.clip(p0, lo, hi)
