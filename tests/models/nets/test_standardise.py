"""One standardisation for every model: constant features (up to round-off) stay unscaled."""
from __future__ import annotations

import numpy as np

from fingertip.models.nets.standardise import STD_FLOOR, constant_features, scale, standardise


def test_columns_are_centred_and_scaled_and_constant_ones_left_alone():
    rng = np.random.default_rng(0)
    x = np.column_stack([rng.normal(5, 2, 1000), np.full(1000, 123456.0),
                         np.full(1000, 0.1) + rng.normal(0, STD_FLOOR / 10, 1000)])
    z, mean, std = standardise(x)
    assert np.allclose(z[:, 0].mean(), 0) and np.isclose(z[:, 0].std(), 1)
    assert std[1] == std[2] == 1.0 and np.allclose(z[:, 1], 0)
    assert constant_features(x).tolist() == [1, 2]


def test_one_scale_for_a_whole_array_computed_in_float64():
    x = (np.arange(24, dtype=np.float32).reshape(2, 3, 4) + 1e4).astype(np.float32)
    mean, std = scale(x, axis=None)
    assert mean.dtype == std.dtype == np.float64
    assert np.isclose(mean, np.arange(24).mean() + 1e4) and np.isclose(std, np.arange(24).std())
    assert scale(np.ones((3, 2)), axis=None)[1] == 1.0
