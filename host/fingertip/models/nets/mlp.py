"""A small multilayer perceptron: trained with numpy, exported to ONNX, run with onnxruntime.

Shared by the force model (regression) and the classifiers. Training needs only numpy
(Adam, mini-batches, early stopping on a validation split); exporting needs the ``onnx``
package (the ``train`` extra); running needs only ``onnxruntime`` and numpy.

The exported graph carries its own input normalisation, so users feed raw features:
``y = softmax?(W_n(...relu(W_1 ((x - mean) / std) + b_1)...) + b_n) * y_scale + y_offset``.
"""
from __future__ import annotations

import json
import logging
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
from scipy.special import softmax

from .inputs import check_training
from .onnx_io import batch_graph, onnx_builder, open_session, save_graph
from .standardise import scale, standardise

log = logging.getLogger(__name__)

Task = Literal["regression", "classification"]


@dataclass
class MLP:
    """Weights and the normalisation around them (float64 for training, float32 exported)."""

    weights: list[np.ndarray]
    biases: list[np.ndarray]
    x_mean: np.ndarray
    x_std: np.ndarray
    task: Task = "regression"
    y_offset: np.ndarray = field(default_factory=lambda: np.zeros(1))
    y_scale: np.ndarray = field(default_factory=lambda: np.ones(1))
    classes: list[str] = field(default_factory=list)

    @property
    def hidden(self) -> tuple[int, ...]:
        return tuple(w.shape[1] for w in self.weights[:-1])

    @property
    def n_params(self) -> int:
        return int(sum(w.size + b.size for w, b in zip(self.weights, self.biases, strict=True)))

    def logits(self, x: np.ndarray) -> np.ndarray:
        """The last layer's output before the softmax or the output scaling (float64)."""
        h = (np.asarray(x, np.float64) - self.x_mean) / self.x_std
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            h = h @ w + b
            if i < len(self.weights) - 1:
                h = np.maximum(h, 0.0)
        return h

    def forward(self, x: np.ndarray) -> np.ndarray:
        """Reference forward pass in float64 (what the ONNX graph must reproduce)."""
        h = self.logits(x)
        if self.task == "classification":
            return softmax(h, axis=-1)
        return h * self.y_scale + self.y_offset


def train_mlp(x: np.ndarray, y: np.ndarray, *, hidden: tuple[int, ...] = (32, 32),
              task: Task = "regression", classes: list[str] | None = None,
              epochs: int = 300, batch: int = 64, lr: float = 3e-3,
              weight_decay: float = 1e-5, val_fraction: float = 0.15, patience: int = 30,
              seed: int = 0) -> MLP:
    """Train with Adam on mini-batches; keep the weights of the best validation loss.

    Regression: ``y`` is (n, outputs) in physical units (standardised inside). Classification:
    ``y`` holds integer labels 0..k-1 (``classes`` names them).
    """
    x, y = check_training(x, y)  # labels are checked below: k may come from them
    rng = np.random.default_rng(seed)
    n, d = x.shape
    xs, x_mean, x_std = standardise(x)
    if task == "classification":
        labels = y.astype(np.int64).reshape(-1)
        k = int(labels.max()) + 1 if classes is None else len(classes)
        if labels.min() < 0 or labels.max() >= k:
            raise ValueError("labels must be 0..classes-1")
        target = np.eye(k)[labels]
        y_offset, y_scale = np.zeros(k), np.ones(k)
    else:
        yf = np.asarray(y, np.float64).reshape(n, -1)
        y_offset, y_scale = scale(yf)
        target = (yf - y_offset) / y_scale
        k = yf.shape[1]
    idx = rng.permutation(n)
    n_val = int(round(n * val_fraction)) if n >= 20 else 0
    val, tr = idx[:n_val], idx[n_val:]
    sizes = [d, *hidden, k]
    ws = [rng.normal(0, math.sqrt(2.0 / a), (a, b)) for a, b in zip(sizes, sizes[1:],
                                                                       strict=False)]
    bs = [np.zeros(b) for b in sizes[1:]]
    # Every parameter is a view of one flat vector, so that each Adam step is a handful
    # of operations on it instead of as many per layer: on small batches the step's
    # Python and allocations cost as much as the products. Element-wise, the same
    # operations in the same order: the same weights to the last bit.
    flat = np.concatenate([p.ravel() for p in ws + bs])
    ws, bs = _views(flat, [w.shape for w in ws]), _views(flat, [b.shape for b in bs],
                                                         sum(w.size for w in ws))
    params = ws + bs
    m = np.zeros_like(flat)
    v = np.zeros_like(flat)
    b1, b2, eps = 0.9, 0.999, 1e-8
    step = 0
    best = (math.inf, flat.copy())
    waited = 0

    def loss_and_grads(xb: np.ndarray, tb: np.ndarray, grads: bool = True):
        acts = [xb]
        h = xb
        for i in range(len(ws)):
            h = h @ ws[i] + bs[i]
            if i < len(ws) - 1:
                h = np.maximum(h, 0.0)
            acts.append(h)
        out = acts[-1]
        # the loss only where it is read (the validation), not at every training step
        if task == "classification":
            # scipy.special.softmax's own operations, without its per-call overhead
            e = np.exp(out - np.max(out, axis=1, keepdims=True))
            p = e / np.sum(e, axis=1, keepdims=True)
            if not grads:
                return -np.mean(np.sum(tb * np.log(p + 1e-12), axis=1)), None
            delta = (p - tb) / len(xb)
        else:
            diff = out - tb
            if not grads:
                return float(np.mean(diff * diff)), None
            delta = 2 * diff / diff.size
        gw, gb = [None] * len(ws), [None] * len(ws)
        for i in range(len(ws) - 1, -1, -1):
            gw[i] = acts[i].T @ delta + weight_decay * ws[i]
            gb[i] = delta.sum(axis=0)
            if i:
                delta = (delta @ ws[i].T) * (acts[i] > 0)
        return None, gw + gb

    for epoch in range(epochs):
        order = rng.permutation(tr)
        for s in range(0, len(order), batch):
            bi = order[s:s + batch]
            _, g = loss_and_grads(xs[bi], target[bi])
            step += 1
            # p -= lr * (m / (1 - b1^t)) / (sqrt(v / (1 - b2^t)) + eps), in place
            g = np.concatenate([a.ravel() for a in g])
            m *= b1
            m += (1 - b1) * g
            v *= b2
            h = (1 - b2) * g
            h *= g
            v += h
            den = v / (1 - b2 ** step)
            np.sqrt(den, out=den)
            den += eps
            upd = m / (1 - b1 ** step)
            upd *= lr
            upd /= den
            flat -= upd
        check = val if n_val else tr
        vloss, _ = loss_and_grads(xs[check], target[check], grads=False)
        if not math.isfinite(vloss):
            raise FloatingPointError(f"training diverged at epoch {epoch} (lower lr?)")
        if vloss < best[0] - 1e-9:
            best = (vloss, flat.copy())
            waited = 0
        else:
            waited += 1
            if waited >= patience:
                break
    params = [p.copy() for p in _views(best[1], [p.shape for p in params])]
    nl = len(ws)
    return MLP(params[:nl], params[nl:], x_mean, x_std, task, y_offset, y_scale,
               list(classes) if classes is not None else [str(i) for i in range(k)]
               if task == "classification" else [])


def _views(flat: np.ndarray, shapes: list[tuple[int, ...]], start: int = 0
           ) -> list[np.ndarray]:
    """Consecutive views of ``flat`` from ``start`` with ``shapes``."""
    out = []
    for shape in shapes:
        n = math.prod(shape)
        out.append(flat[start:start + n].reshape(shape))
        start += n
    return out


# --- ONNX ---------------------------------------------------------------------------------

def folded_layers(model: MLP) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The layers with the input normalisation folded into the first and the output scaling
    into the last (float64), so that the graph is MatMul, Add and Relu only.

    Per frame, onnxruntime's cost is mostly per node (a force estimate is 3 nodes instead of
    7 after its own fusions). In float32 the folded first layer loses about
    log10(1 + |x_mean| / x_std) digits to cancellation against its bias: at most one or two
    for tared counts, far below the models' error (tests/models/nets/test_mlp.py checks it at the
    24-bit extremes).
    """
    w = [np.asarray(x, np.float64) for x in model.weights]
    b = [np.asarray(x, np.float64) for x in model.biases]
    std = np.asarray(model.x_std, np.float64)
    mean = np.asarray(model.x_mean, np.float64)
    w[0] = w[0] / std[:, None]
    b[0] = b[0] - (mean / std) @ model.weights[0]
    if model.task != "classification":
        scale = np.asarray(model.y_scale, np.float64)
        w[-1] = w[-1] * scale
        b[-1] = b[-1] * scale + np.asarray(model.y_offset, np.float64)
    return w, b


def layer_nodes(model: MLP, input_name: str, output_name: str, prefix: str = ""
                ) -> tuple[list, list]:
    """(nodes, initialisers) of the layers from ``input_name`` to the last layer's output
    ``output_name`` (logits for a classifier; scaled outputs for a regression), names
    prefixed with ``prefix`` so that several models fit in one graph."""
    _, _, helper, numpy_helper = onnx_builder()
    weights, biases = folded_layers(model)
    inits, nodes, h = [], [], input_name
    last = len(weights) - 1
    for i, (w, b) in enumerate(zip(weights, biases, strict=True)):
        inits += [numpy_helper.from_array(w.astype(np.float32), f"{prefix}W{i}"),
                  numpy_helper.from_array(b.astype(np.float32), f"{prefix}b{i}")]
        z = output_name if i == last else f"{prefix}z{i}"
        nodes += [helper.make_node("MatMul", [h, f"{prefix}W{i}"], [f"{prefix}m{i}"]),
                  helper.make_node("Add", [f"{prefix}m{i}", f"{prefix}b{i}"], [z])]
        h = z
        if i < last:
            nodes.append(helper.make_node("Relu", [h], [f"{prefix}r{i}"]))
            h = f"{prefix}r{i}"
    return nodes, inits


def to_onnx(model: MLP, path: str | Path, *, input_name: str = "features",
            output_name: str | None = None, metadata: dict | None = None,
            opset: int = 17) -> Path:
    """Write the MLP as an ONNX graph (float32, any batch size). Needs the ``onnx`` package."""
    _, _, helper, _ = onnx_builder()
    out_name = output_name or ("probabilities" if model.task == "classification"
                               else "outputs")
    d = model.weights[0].shape[0]
    k = model.weights[-1].shape[1]
    classify = model.task == "classification"
    nodes, inits = layer_nodes(model, input_name, "logits" if classify else out_name)
    if classify:
        nodes.append(helper.make_node("Softmax", ["logits"], [out_name], axis=1))
    graph = batch_graph(nodes, "fingertip_mlp", (input_name, d), (out_name, k), inits)
    meta = {"task": model.task, "classes": json.dumps(model.classes),
            "hidden": json.dumps(list(model.hidden))}
    return save_graph(graph, path, {**meta, **(metadata or {})}, opset)


class OnnxModel:
    """An ONNX model run with onnxruntime on the CPU: single rows or batches, float32."""

    def __init__(self, path: str | Path, threads: int = 1) -> None:
        self.session = open_session(path, threads)
        self.path = Path(path)
        inp = self.session.get_inputs()[0]
        self.input_name = inp.name
        self.n_features = inp.shape[-1] if isinstance(inp.shape[-1], int) else None
        self.output_name = self.session.get_outputs()[0].name
        self.metadata = dict(self.session.get_modelmeta().custom_metadata_map)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        a = np.asarray(x, dtype=np.float32)
        single = a.ndim == 1
        if single:
            a = a[None, :]
        if self.n_features is not None and a.shape[-1] != self.n_features:
            raise ValueError(f"{self.path.name} takes {self.n_features} features, got "
                             f"{a.shape[-1]}")
        out = self.session.run([self.output_name], {self.input_name: a})[0]
        return out[0] if single else out
