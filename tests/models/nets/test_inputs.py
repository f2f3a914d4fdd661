"""One check of training inputs for every trainer: the same one-line refusals everywhere."""
from __future__ import annotations

import numpy as np
import pytest

from fingertip.models.nets.cnn import train_cnn
from fingertip.models.nets.inputs import check_training
from fingertip.models.nets.linear import train_logistic
from fingertip.models.nets.mlp import train_mlp


@pytest.mark.parametrize("x,y,match", [
    (np.zeros((4, 3)), np.zeros(5), "need X of shape"),
    (np.zeros((0, 3)), np.zeros(0), "need X of shape"),
    (np.full((4, 3), np.nan), np.zeros(4), "inputs contain NaN"),
    (np.zeros((4, 3)), np.array([0, 1, 2, 0]), "labels must be 0..classes-1"),
])
def test_every_classifier_trainer_refuses_the_same_way(x, y, match):
    with pytest.raises(ValueError, match=match):
        train_logistic(x, y, classes=["a", "b"])
    with pytest.raises(ValueError, match=match):
        train_cnn(x.reshape(len(x), 3, 1), y, classes=["a", "b"])
    with pytest.raises(ValueError, match=match.replace("NaN", "")):
        check_training(x, y, classes=2)


def test_regression_targets_must_be_finite_and_arrays_come_back_typed():
    with pytest.raises(ValueError, match="targets contain NaN"):
        train_mlp(np.zeros((4, 2)), np.array([1.0, np.inf, 0.0, 0.0]))
    x, y = check_training([[1, 2]], [3], ndim=2, dtype=np.float32)
    assert x.dtype == np.float32 and y.tolist() == [3]
