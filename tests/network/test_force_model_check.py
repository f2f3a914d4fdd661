"""`publish --force-model FORCE.onnx` checks the model against each live fingertip, as
`stream` and `record` do: one that does not fit is refused with the reason, before anything
is published."""
from __future__ import annotations

import numpy as np

from fingertip.models.force.calibrate import fit_model

from .conftest import start


def _model(path, **meta):
    rng = np.random.default_rng(0)
    counts = rng.normal(0, 1e5, (200, 4))
    m = fit_model("affine", counts, counts[:, :2] * 1e-5)
    base = {"fingertip_model": "force", "channels": 4, "units": "N", "counts_gain": 128}
    return m.to_onnx(path, {**base, **meta})


def test_a_model_in_other_units_is_refused(tmp_path):
    pub = start("publish", "--virtual", "1", "--name", "index", "--force-model",
                str(_model(tmp_path / "lbf.onnx", units="lbf")), "--duration", "2")
    _, err = pub.communicate(timeout=60)
    assert pub.returncode == 2, err
    lines = [x for x in err.splitlines() if x.startswith("ERROR")]
    assert len(lines) == 1 and "not newtons" in lines[0], err


def test_a_fitting_model_is_published(tmp_path):
    pub = start("publish", "--virtual", "1", "--name", "index", "--force-model",
                str(_model(tmp_path / "n.onnx")), "--duration", "1")
    _, err = pub.communicate(timeout=60)
    assert pub.returncode == 0, err
    assert "/fingertip/index/wrench" in err
