"""Standardisation of training inputs: one rule, one floor, for every model.

A model subtracts each feature's mean and divides by its standard deviation before its first
layer (its ONNX graph does the same). A feature whose deviation is below :data:`STD_FLOOR`
is constant up to round-off: it carries nothing, so it is left unscaled (deviation 1) rather
than blown up into noise.
"""
from __future__ import annotations

import numpy as np

STD_FLOOR = 1e-9
"""Deviations below this count as zero (a constant feature; float round-off of a constant
column of large counts is about 1e-11)."""


def scale(x: np.ndarray, axis: int | None = 0) -> tuple[np.ndarray, np.ndarray]:
    """``(mean, std)`` of ``x`` over ``axis`` (None: one for the whole array), computed in
    float64; a constant feature's ``std`` is 1."""
    x = np.asarray(x)
    mean = x.mean(axis=axis, dtype=np.float64)
    std = x.std(axis=axis, dtype=np.float64)
    return mean, np.where(std < STD_FLOOR, 1.0, std)


def standardise(x: np.ndarray, axis: int | None = 0
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(z, mean, std)`` with ``z = (x - mean) / std`` (float64) and ``mean``, ``std`` as
    :func:`scale` gives them."""
    x = np.asarray(x, np.float64)
    mean, std = scale(x, axis)
    return (x - mean) / std, mean, std


def constant_features(x: np.ndarray) -> np.ndarray:
    """Indices of the columns of ``x`` (rows = samples) that :func:`scale` leaves unscaled
    because they do not vary."""
    return np.flatnonzero(np.asarray(x).std(axis=0, dtype=np.float64) < STD_FLOOR)
