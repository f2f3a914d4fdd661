"""Two models from scikit-learn on the spectral statistics of a window (the mean, the
deviation and the 90th percentile over time of each log band): an RBF-kernel support
vector machine and boosted trees (histogram gradient boosting), exported to ONNX with
skl2onnx, the converters scikit-learn's maintainers keep.

Both are candidates of the material trainer (:mod:`.candidates`): a plain RBF SVM on these
statistics, a few lines of scikit-learn, reached 91.2 % on 1,000 real slides of 1 s where
the trainer's own candidates stopped at 90.9 % (issue 29), so the trainer tries it and
keeps it when the cross-validation says it pays. The exported graph takes the same float32
rows as the float64 model (scikit-learn's) and ends with the trainer's temperature:
``softmax(log(p) / T)``, the scaling that
:func:`~fingertip.models.vibration.reliability.apply_temperature` applies to every other
candidate.
"""
from __future__ import annotations

import json
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ...outputs import atomic_output
from ..nets.onnx_io import onnx_builder

SVM_C = 10.0
"""The SVM's penalty on standardised inputs (``gamma="scale"``); the sets tried (1,000
simulated slides of 1 s, 20 textures) moved by under a point between C = 3 and 30."""
BOOST_ROUNDS = 30
BOOST_LEAVES = 8
BOOST_RATE = 0.2
BOOST_ROWS = 3000
"""Boosted trees grow one tree per class and round: at 100 rounds of 15 leaves on 6,000
rows, 30 textures took over 9 minutes of cross-validation at load average 20 (the SVM 52
s), so they get fewer, smaller trees, a higher rate and fewer rows."""
MAX_ROWS = 6000
"""At most this many training rows (chosen evenly over the recordings, reproducibly): an
RBF SVM's fit grows with the square of its rows, and windows of one recording are alike."""
PROB_FLOOR = 1e-12
OUTPUT = "probabilities_t"
"""The graph's one output (skl2onnx's own is ``probabilities``, before the temperature)."""


@dataclass
class SpectralModel:
    """A fitted scikit-learn classifier and what its ONNX export needs."""

    estimator: Any
    n_inputs: int
    kind: str
    """``svm`` or ``boost``."""
    classes: list[str] = field(default_factory=list)

    @property
    def n_params(self) -> int:
        est = self.estimator
        if self.kind == "svm":
            svc = est[-1]
            return int(svc.support_vectors_.size + svc.dual_coef_.size
                       + svc.intercept_.size + 2 * self.n_inputs)
        # boosted trees: every node of every tree holds a feature, threshold and value
        return int(sum(len(p.nodes) for row in est._predictors for p in row) * 3)

    def forward(self, x: np.ndarray) -> np.ndarray:
        """Class probabilities in float64 (the reference of the ONNX graph)."""
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FutureWarning)  # see train_svm
            return self.estimator.predict_proba(np.asarray(x, np.float64))


def _rows(n: int, groups: np.ndarray, limit: int) -> np.ndarray:
    """Indices of at most ``limit`` of ``n`` rows, the same share of every recording."""
    if n <= limit:
        return np.arange(n)
    keep = np.zeros(n, bool)
    for g in np.unique(groups):
        idx = np.flatnonzero(groups == g)
        k = max(1, int(round(len(idx) * limit / n)))
        keep[idx[np.unique(np.linspace(0, len(idx) - 1, k).round().astype(np.intp))]] = True
    return np.flatnonzero(keep)


def _weights(groups: np.ndarray) -> np.ndarray:
    """Every recording weighs the same (long recordings give more windows, not more say),
    scaled to a mean of 1 (the SVM's C keeps its meaning)."""
    _, inv, counts = np.unique(groups, return_inverse=True, return_counts=True)
    w = 1.0 / counts[inv]
    return w * (len(w) / w.sum())


def train_svm(x: np.ndarray, y: np.ndarray, groups: np.ndarray, classes: list[str],
              seed: int = 0) -> SpectralModel:
    """Standardised inputs, RBF kernel, probabilities by libsvm's Platt scaling."""
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler
    from sklearn.svm import SVC

    rows = _rows(len(x), groups, MAX_ROWS)
    xs, ys, gs = np.asarray(x, np.float64)[rows], y[rows], groups[rows]
    est = make_pipeline(StandardScaler(), SVC(C=SVM_C, gamma="scale", probability=True,
                                               random_state=seed))
    with warnings.catch_warnings():
        # scikit-learn 1.9 deprecates probability=True (removed in 1.11) for a calibrated
        # wrapper; skl2onnx 1.20 converts this form, the pinned versions keep it
        warnings.simplefilter("ignore", FutureWarning)
        est.fit(xs, ys, svc__sample_weight=_weights(gs))
    _check_classes(est, len(classes))
    return SpectralModel(est, x.shape[1], "svm", list(classes))


def train_boost(x: np.ndarray, y: np.ndarray, groups: np.ndarray, classes: list[str],
                seed: int = 0) -> SpectralModel:
    """Histogram gradient boosting, a fixed number of rounds (no early stopping: its
    validation rows would share recordings with the training rows)."""
    from sklearn.ensemble import HistGradientBoostingClassifier

    rows = _rows(len(x), groups, BOOST_ROWS)
    est = HistGradientBoostingClassifier(max_iter=BOOST_ROUNDS, learning_rate=BOOST_RATE,
                                         max_leaf_nodes=BOOST_LEAVES, early_stopping=False,
                                         random_state=seed)
    est.fit(np.asarray(x, np.float64)[rows], y[rows],
            sample_weight=_weights(groups[rows]))
    _check_classes(est, len(classes))
    return SpectralModel(est, x.shape[1], "boost", list(classes))


def _check_classes(est: Any, k: int) -> None:
    got = list(getattr(est, "classes_", []))
    if got != list(range(k)):
        raise ValueError(f"every class needs training rows: got classes {got} of {k}")


@contextmanager
def _int_missing_flags() -> Iterator[None]:
    """skl2onnx 1.20 passes a leaf's missing-value flag as a Python bool, which onnx 1.23
    refuses in an integer list ("Expected an int, got a boolean"): convert it to 0/1 while
    boosted trees are converted (the flag only matters for NaN inputs, which features never
    hold)."""
    from skl2onnx.common import tree_ensemble

    add_node = tree_ensemble.add_node

    def fixed(*args: Any, nodes_missing_value_tracks_true: Any = 0, **kw: Any) -> Any:
        return add_node(*args, nodes_missing_value_tracks_true=int(
            nodes_missing_value_tracks_true), **kw)

    tree_ensemble.add_node = fixed
    try:
        yield
    finally:
        tree_ensemble.add_node = add_node


def to_onnx(model: SpectralModel, path: str | Path, *, temperature: float = 1.0,
            input_name: str = "features", metadata: dict | None = None,
            opset: int = 17) -> Path:
    """skl2onnx's graph of the estimator (float32 rows in, probabilities out), then
    ``softmax(log(max(p, 1e-12)) / temperature)``; the label output is dropped."""
    onnx, TensorProto, helper, numpy_helper = onnx_builder()
    from skl2onnx import convert_sklearn
    from skl2onnx.common.data_types import FloatTensorType

    if not temperature > 0:
        raise ValueError("temperature must be positive")
    est = model.estimator
    final = est[-1] if hasattr(est, "steps") else est
    with warnings.catch_warnings(), _int_missing_flags():
        warnings.simplefilter("ignore", FutureWarning)  # see train_svm
        m = convert_sklearn(est, initial_types=[(input_name, FloatTensorType([None,
                                                                          model.n_inputs]))],
                            options={id(final): {"zipmap": False}},
                            target_opset={"": opset, "ai.onnx.ml": 3})
    g = m.graph
    prob = g.output[-1].name
    k = len(model.classes)
    g.initializer.extend([numpy_helper.from_array(np.array(PROB_FLOOR, np.float32),
                                                  "t_floor"),
                          numpy_helper.from_array(np.array(1.0 / temperature, np.float32),
                                                  "t_inv")])
    g.node.extend([helper.make_node("Max", [prob, "t_floor"], ["t_clipped"]),
                   helper.make_node("Log", ["t_clipped"], ["t_logp"]),
                   helper.make_node("Mul", ["t_logp", "t_inv"], ["t_scaled"]),
                   helper.make_node("Softmax", ["t_scaled"], [OUTPUT], axis=1)])
    del g.output[:]
    g.output.append(helper.make_tensor_value_info(OUTPUT, TensorProto.FLOAT,
                                                  ["batch", k]))
    meta = {"task": "classification", "classes": json.dumps(model.classes),
            "estimator": type(final).__name__, "temperature": json.dumps(temperature),
            **(metadata or {})}
    helper.set_model_props(m, {kk: v if isinstance(v, str) else json.dumps(v)
                               for kk, v in meta.items()})
    m.producer_name = "fingertip (skl2onnx)"
    onnx.checker.check_model(m)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(path) as tmp:  # a reader never sees half a model
        onnx.save(m, str(tmp))
    return path
