"""The confusion-matrix PNG stays a readable, bounded picture however many classes a
dataset has (a folder of 100 textures once drew an 8500-pixel square and took 3 GB)."""
from __future__ import annotations

import struct

import numpy as np
import pytest

from fingertip.models.vibration.classifier.evaluation import (
    CONFUSION_MAX_INCHES,
    Evaluation,
    plot_confusion,
)


def _png_size(path) -> tuple[int, int]:
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", head[16:24])


@pytest.mark.parametrize("k", [3, 120])
def test_confusion_png_is_bounded(tmp_path, k):
    rng = np.random.default_rng(0)
    cm = rng.integers(0, 5, (k, k)) + np.diag(rng.integers(5, 20, k))
    ev = Evaluation([f"texture_{i:03d}" for i in range(k)], cm)
    w, h = _png_size(plot_confusion(ev, tmp_path / f"c{k}.png"))
    assert 100 < h and w < 2 * 110 * (CONFUSION_MAX_INCHES + 1.2)
    assert h < 2 * 110 * CONFUSION_MAX_INCHES
