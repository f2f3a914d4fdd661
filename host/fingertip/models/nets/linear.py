"""Multinomial logistic regression: fitted with numpy and scipy (L-BFGS), exported to ONNX.

The plain, strong baseline of the vibration classifiers: standardised features, one weight
per feature and class, an L2 penalty, softmax. The exported graph is ``Gemm`` + ``Softmax``
(the standardisation and a temperature folded into the weights), run with onnxruntime like
the MLPs of :mod:`.mlp`. The L2 strength is chosen by an inner split of the training rows
(``l2=None``) when the caller does not fix it.
"""
from __future__ import annotations

import json
import logging
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.special import softmax

from .inputs import check_training
from .onnx_io import batch_graph, onnx_builder, save_graph
from .standardise import standardise

log = logging.getLogger(__name__)

L2_GRID = (1e-4, 1e-3, 1e-2, 1e-1)
"""Penalties tried (per row, on standardised features) when ``l2`` is not given."""
MAX_ITER = 200
"""L-BFGS iterations per fit at most. The weakest penalties stop at this cap rather than at
the tolerance; 500 (until 2026-11-27) took 2.5 times the CPU of 200 on the vibration
trainer's folds for the same held-out accuracy within 0.35 points per fold (1,000 slides of
1 s, 20 textures, and the 700 slides of 2 s: docs/classifiers.md)."""


@dataclass
class Logistic:
    """``softmax(((x - mean) / std) @ w + b)`` (float64 reference of the ONNX graph)."""

    w: np.ndarray
    b: np.ndarray
    x_mean: np.ndarray
    x_std: np.ndarray
    classes: list[str] = field(default_factory=list)
    l2: float = 0.0

    @property
    def n_params(self) -> int:
        return int(self.w.size + self.b.size)

    def logits(self, x: np.ndarray) -> np.ndarray:
        return ((np.asarray(x, np.float64) - self.x_mean) / self.x_std) @ self.w + self.b

    def forward(self, x: np.ndarray) -> np.ndarray:
        return softmax(self.logits(x), axis=-1)


def _fit(xs: np.ndarray, y: np.ndarray, k: int, l2: float, weights: np.ndarray,
         w0: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    from scipy.optimize import minimize

    n, d = xs.shape
    wn = weights / float(weights.sum())
    onehot = np.zeros((k, n))
    onehot[y, np.arange(n)] = 1.0
    # Class-major (k x n) logits and both layouts of the rows: with few classes, ``w.T @
    # xt`` and ``e @ xs`` run about twice as fast as ``xs @ w`` and ``xs.T @ e`` (BLAS
    # streams the long axis), and the max and sums over the classes become element-wise
    # operations on rows of n instead of reductions over rows of k (a tenth of the time).
    # The same loss and gradient; L-BFGS calls this hundreds of times.
    xt = np.ascontiguousarray(xs.T)

    def f(theta: np.ndarray) -> tuple[float, np.ndarray]:
        # the weighted mean log-loss and its gradient, with one exp per entry
        w = theta[:d * k].reshape(d, k)
        z = w.T @ xt
        z += theta[d * k:, None]
        z -= z.max(axis=0)
        e = np.exp(z)
        total = e.sum(axis=0)
        loss = -float(np.sum((z * onehot) @ wn) - wn @ np.log(total)) \
            + 0.5 * l2 * float(np.sum(w * w))
        e /= total
        e -= onehot
        e *= wn
        gw = (e @ xs).T
        gw += l2 * w
        return loss, np.concatenate([gw.ravel(), e.sum(axis=1)])

    theta0 = np.zeros(d * k + k) if w0 is None else w0
    res = minimize(f, theta0, jac=True, method="L-BFGS-B",
                   options={"maxiter": MAX_ITER, "gtol": 1e-6})
    if not np.all(np.isfinite(res.x)):
        raise FloatingPointError("logistic regression diverged")
    return res.x[:d * k].reshape(d, k), res.x[d * k:]


def train_logistic(x: np.ndarray, y: np.ndarray, *, classes: list[str],
                   l2: float | None = None, groups: np.ndarray | None = None,
                   seed: int = 0, start: Logistic | None = None) -> Logistic:
    """Fit on rows ``x`` with integer labels ``y``.

    ``groups``: the recording of each row; rows are weighted so that every recording counts
    the same (long recordings give more windows, not more say), and the inner split that
    picks ``l2`` (when None) is by recording, so that correlated windows of one recording
    never sit on both sides. ``start``: a model of the same inputs and classes whose weights
    the optimisation starts from (a fit on much the same rows converges in fewer steps).
    """
    k = len(classes)
    x, y = check_training(x, y, classes=k)
    g = np.arange(len(y)) if groups is None else np.asarray(groups)
    _, inv, counts = np.unique(g, return_inverse=True, return_counts=True)
    weights = 1.0 / counts[inv]
    xs, mean, std = standardise(x)
    w0 = None
    if l2 is None:
        # the fit starts from the chosen penalty's inner-split weights: on three quarters
        # of the same rows, they are most of the way there
        l2, w0 = _choose_l2(xs, y, k, g, weights, seed)
    if start is not None and start.w.shape == (x.shape[1], k):
        w0 = np.concatenate([start.w.ravel(), start.b])
    w, b = _fit(xs, y, k, l2, weights, w0)
    return Logistic(w, b, mean, std, list(classes), float(l2))


def _choose_l2(xs: np.ndarray, y: np.ndarray, k: int, g: np.ndarray, weights: np.ndarray,
               seed: int) -> tuple[float, np.ndarray | None]:
    """The penalty of :data:`L2_GRID` with the best held-out log-loss on a quarter of the
    recordings (stratified), and its weights there (flat, as :func:`_fit` starts from); the
    middle of the grid (and None) when there are too few recordings."""
    rng = np.random.default_rng(seed + 7)
    held = []
    for c in range(k):
        recs = np.unique(g[y == c])
        if len(recs) >= 4:
            held += rng.permutation(recs)[:max(1, len(recs) // 4)].tolist()
    if not held:
        return L2_GRID[len(L2_GRID) // 2], None
    te = np.isin(g, held)
    tr = ~te
    best, best_l2, theta, best_theta = math.inf, L2_GRID[-1], None, None
    for l2 in sorted(L2_GRID, reverse=True):  # strong to weak: warm starts converge fast
        w, b = _fit(xs[tr], y[tr], k, l2, weights[tr], theta)
        theta = np.concatenate([w.ravel(), b])
        p = softmax(xs[te] @ w + b, axis=1)
        loss = -float(np.sum(weights[te] * np.log(p[np.arange(len(p)), y[te]] + 1e-12))
                      / weights[te].sum())
        if loss < best - 1e-9:
            best, best_l2, best_theta = loss, l2, theta
    return best_l2, best_theta


def logit_nodes(model: Logistic, input_name: str, output_name: str, prefix: str = "",
                temperature: float = 1.0) -> tuple[list, list]:
    """(nodes, initialisers) computing ``logits / temperature`` from ``input_name`` into
    ``output_name`` (one ``Gemm``, the standardisation folded into its weights); names are
    prefixed with ``prefix`` so that several models fit in one graph."""
    _, _, helper, numpy_helper = onnx_builder()
    w = model.w / model.x_std[:, None] / temperature
    b = (model.b - (model.x_mean / model.x_std) @ model.w) / temperature
    inits = [numpy_helper.from_array(w.astype(np.float32), f"{prefix}W"),
             numpy_helper.from_array(b.astype(np.float32), f"{prefix}b")]
    return [helper.make_node("Gemm", [input_name, f"{prefix}W", f"{prefix}b"],
                             [output_name])], inits


def to_onnx(model: Logistic, path: str | Path, *, temperature: float = 1.0,
            input_name: str = "features", metadata: dict | None = None,
            opset: int = 17) -> Path:
    """Write ``softmax(logits / temperature)`` as a Gemm + Softmax graph (float32)."""
    _, _, helper, _ = onnx_builder()
    if not temperature > 0:
        raise ValueError("temperature must be positive")
    d, k = model.w.shape
    nodes, inits = logit_nodes(model, input_name, "logits", temperature=temperature)
    nodes.append(helper.make_node("Softmax", ["logits"], ["probabilities"], axis=1))
    graph = batch_graph(nodes, "fingertip_logistic", (input_name, d), ("probabilities", k),
                        inits)
    meta = {"task": "classification", "classes": json.dumps(model.classes),
            "l2": json.dumps(model.l2), "temperature": json.dumps(temperature)}
    return save_graph(graph, path, {**meta, **(metadata or {})}, opset)
