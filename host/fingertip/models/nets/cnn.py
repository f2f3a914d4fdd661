"""A small ResNet-style CNN over (time x frequency) spectrogram windows, in numpy.

Trained with numpy (im2col convolutions, Adam, early stopping on held-out recordings),
exported to ONNX (``Conv``/``Relu``/``Add``/``GlobalAveragePool``/``Gemm``/``Softmax``, opset
17) and run with onnxruntime, like the MLPs of :mod:`.mlp`. No PyTorch.

Architecture (the defaults, about 20 k parameters)::

    window (86 frames x 32 bands, dB) -> (x - mean) / std       scalars learnt from the data
    stem   conv 3x3, 1 -> 8, stride 2, ReLU                     43 x 16
    block  [conv 3x3 -> ReLU -> conv 3x3] + identity, ReLU       8 ch, 43 x 16
    block  [conv 3x3 s2 -> ReLU -> conv 3x3] + 1x1 s2, ReLU     16 ch, 22 x 8
    block  [conv 3x3 s2 -> ReLU -> conv 3x3] + 1x1 s2, ReLU     32 ch, 11 x 4
    global average pooling -> dense 32 -> ReLU -> dense k -> softmax

No batch normalisation: the second convolution of each residual branch starts at zero
(each block starts as the identity, as in Fixup), which trains stably with Adam at this size.
Internally tensors are NHWC (H = frames, W = bands) so that an im2col convolution is one
matrix product; the ONNX graph is NCHW.
"""
from __future__ import annotations

import contextlib
import ctypes
import json
import logging
import math
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.special import softmax

from .inputs import check_training
from .onnx_io import onnx_builder, save_graph
from .standardise import scale

log = logging.getLogger(__name__)


_BLAS_SYMBOLS = (("scipy_openblas_set_num_threads64_", "scipy_openblas_get_num_threads64_"),
                 ("scipy_openblas_set_num_threads", "scipy_openblas_get_num_threads"),
                 ("openblas_set_num_threads64_", "openblas_get_num_threads64_"),
                 ("openblas_set_num_threads", "openblas_get_num_threads"))


def _openblas_handles() -> list[tuple[ctypes._CFuncPtr, ctypes._CFuncPtr]]:
    out = []
    try:
        with open("/proc/self/maps", encoding="utf-8") as f:
            libs = {line.split()[-1] for line in f if "openblas" in line.lower()}
    except OSError:
        return out
    for lib in sorted(libs):
        try:
            dll = ctypes.CDLL(lib)
        except OSError:
            continue
        for set_name, get_name in _BLAS_SYMBOLS:
            if hasattr(dll, set_name) and hasattr(dll, get_name):
                out.append((getattr(dll, set_name), getattr(dll, get_name)))
                break
    return out


@contextlib.contextmanager
def blas_threads(n: int = 1) -> Iterator[None]:
    """Limit OpenBLAS to ``n`` threads inside the block (restored after).

    The convolutions here are many small matrix products: on a shared machine with two
    cores, OpenBLAS's threads made them up to 20 times slower than one thread. Linux only
    (reads /proc/self/maps); elsewhere a no-op.
    """
    handles = _openblas_handles()
    before = [get() for _, get in handles]
    for set_, _ in handles:
        set_(ctypes.c_int(n))
    try:
        yield
    finally:
        for (set_, _), b in zip(handles, before, strict=True):
            set_(ctypes.c_int(b))


@dataclass(frozen=True)
class CnnSpec:
    frames: int = 86
    bands: int = 32
    channels: tuple[int, ...] = (8, 16, 32)
    """Channels of the stem (and of the first block), then of each further block (each
    further block halves time and frequency)."""
    head: int = 32
    """Hidden units of the classifier head (0: a linear head)."""
    n_classes: int = 3

    def blocks(self) -> list[tuple[int, int, int]]:
        """(in channels, out channels, stride) of each residual block."""
        ch = self.channels
        out = [(ch[0], ch[0], 1)]
        out += [(a, b, 2) for a, b in zip(ch[:-1], ch[1:], strict=True)]
        return out


def _out_size(n: int, k: int, s: int, p: int) -> int:
    return (n + 2 * p - k) // s + 1


def _im2col(x: np.ndarray, k: int, s: int, p: int) -> tuple[np.ndarray, int, int]:
    """(N, H, W, C) -> (N * Ho * Wo, C * k * k) patches, ordered (C, kh, kw)."""
    n, h, w, c = x.shape
    if p:
        x = np.pad(x, ((0, 0), (p, p), (p, p), (0, 0)))
    if k == 1:
        v = x[:, ::s, ::s, :]
        ho, wo = v.shape[1], v.shape[2]
        return np.ascontiguousarray(v).reshape(n * ho * wo, c), ho, wo
    win = np.lib.stride_tricks.sliding_window_view(x, (k, k), axis=(1, 2))[:, ::s, ::s]
    ho, wo = win.shape[1], win.shape[2]
    return win.reshape(n * ho * wo, c * k * k), ho, wo


def _col2im(dcols: np.ndarray, shape: tuple[int, ...], k: int, s: int, p: int,
            ho: int, wo: int) -> np.ndarray:
    """Adjoint of :func:`_im2col`: scatter-add the patch gradients back (k*k slices)."""
    n, h, w, c = shape
    if k == 1:
        dx = np.zeros(shape, dtype=dcols.dtype)
        dx[:, ::s, ::s, :][:, :ho, :wo] = dcols.reshape(n, ho, wo, c)
        return dx
    d = dcols.reshape(n, ho, wo, c, k, k)
    dxp = np.zeros((n, h + 2 * p, w + 2 * p, c), dtype=dcols.dtype)
    for i in range(k):      # k*k = 9 vectorised slices per convolution, not per pixel
        for j in range(k):
            dxp[:, i:i + s * ho:s, j:j + s * wo:s, :] += d[..., i, j]
    return dxp[:, p:p + h, p:p + w, :]


@dataclass
class SmallResNet:
    spec: CnnSpec
    params: dict[str, np.ndarray]
    x_mean: float = 0.0
    x_std: float = 1.0
    classes: list[str] = field(default_factory=list)

    # --- construction -----------------------------------------------------------------

    @classmethod
    def init(cls, spec: CnnSpec, seed: int = 0, classes: list[str] | None = None
             ) -> SmallResNet:
        rng = np.random.default_rng(seed)

        def he(fan_in: int, shape: tuple[int, ...]) -> np.ndarray:
            return rng.normal(0, math.sqrt(2.0 / fan_in), shape)

        p: dict[str, np.ndarray] = {}
        c0 = spec.channels[0]
        p["stem.w"], p["stem.b"] = he(9, (9, c0)), np.zeros(c0)
        for i, (a, b, s) in enumerate(spec.blocks()):
            p[f"b{i}.c1.w"], p[f"b{i}.c1.b"] = he(9 * a, (9 * a, b)), np.zeros(b)
            p[f"b{i}.c2.w"], p[f"b{i}.c2.b"] = np.zeros((9 * b, b)), np.zeros(b)  # Fixup
            if a != b or s != 1:
                p[f"b{i}.proj.w"], p[f"b{i}.proj.b"] = he(a, (a, b)), np.zeros(b)
        last = spec.channels[-1]
        if spec.head:
            p["head.w"], p["head.b"] = he(last, (last, spec.head)), np.zeros(spec.head)
            last = spec.head
        p["out.w"] = rng.normal(0, math.sqrt(1.0 / last), (last, spec.n_classes))
        p["out.b"] = np.zeros(spec.n_classes)
        names = list(classes) if classes else [str(i) for i in range(spec.n_classes)]
        return cls(spec, p, 0.0, 1.0, names)

    @property
    def n_params(self) -> int:
        return int(sum(v.size for v in self.params.values()))

    # --- forward / backward -------------------------------------------------------------

    def _conv(self, name: str, x: np.ndarray, k: int, s: int, cache: dict | None,
              params: dict[str, np.ndarray]) -> np.ndarray:
        p = k // 2
        cols, ho, wo = _im2col(x, k, s, p)
        w, b = params[name + ".w"], params[name + ".b"]
        y = cols @ w
        y += b
        if cache is not None:
            cache[name] = (cols, x.shape, k, s, p, ho, wo)
        return y.reshape(x.shape[0], ho, wo, w.shape[1])

    def forward(self, x: np.ndarray, dtype: type = np.float64, cache: dict | None = None,
                params: dict[str, np.ndarray] | None = None) -> np.ndarray:
        """Class probabilities (N, k) for windows ``x`` (N, frames, bands) in dB.

        ``dtype`` float64 is the reference the ONNX graph must reproduce in float32;
        ``cache`` (a dict) collects what :meth:`backward` needs.
        """
        prm = params if params is not None else {k: v.astype(dtype, copy=False)
                                                 for k, v in self.params.items()}
        x = np.asarray(x, dtype=dtype)
        if x.ndim != 3 or x.shape[1:] != (self.spec.frames, self.spec.bands):
            raise ValueError(f"the CNN takes windows of ({self.spec.frames}, "
                             f"{self.spec.bands}), got {x.shape[1:]}")
        c = cache if cache is not None else None
        h = ((x - dtype(self.x_mean)) / dtype(self.x_std))[..., None]
        h = np.maximum(self._conv("stem", h, 3, 2, c, prm), 0)
        if c is not None:
            c["stem.relu"] = h
        for i, (_, _, s) in enumerate(self.spec.blocks()):
            r = np.maximum(self._conv(f"b{i}.c1", h, 3, s, c, prm), 0)
            r = self._conv(f"b{i}.c2", r if c is None else c.setdefault(f"b{i}.r1", r), 3, 1,
                           c, prm)
            sc = self._conv(f"b{i}.proj", h, 1, s, c, prm) if f"b{i}.proj.w" in prm else h
            h = np.maximum(r + sc, 0)
            if c is not None:
                c[f"b{i}.out"] = h
        g = h.mean(axis=(1, 2))
        if c is not None:
            c["gap_shape"] = h.shape
        if self.spec.head:
            z = np.maximum(g @ prm["head.w"] + prm["head.b"], 0)
            if c is not None:
                c["head_in"], c["head_out"] = g, z
            g = z
        if c is not None:
            c["out_in"] = g
        return softmax(g @ prm["out.w"] + prm["out.b"], axis=1)

    def backward(self, c: dict, dlogits: np.ndarray, prm: dict[str, np.ndarray]
                 ) -> dict[str, np.ndarray]:
        """Gradients of every parameter from the forward ``cache`` and d(loss)/d(logits)."""
        grads: dict[str, np.ndarray] = {}

        def conv_back(name: str, dy: np.ndarray, need_dx: bool = True) -> np.ndarray | None:
            cols, xshape, k, s, p, ho, wo = c[name]
            w = prm[name + ".w"]
            d2 = dy.reshape(-1, w.shape[1])
            grads[name + ".w"] = cols.T @ d2
            grads[name + ".b"] = d2.sum(axis=0)
            return _col2im(d2 @ w.T, xshape, k, s, p, ho, wo) if need_dx else None

        grads["out.w"] = c["out_in"].T @ dlogits
        grads["out.b"] = dlogits.sum(axis=0)
        dg = dlogits @ prm["out.w"].T
        if self.spec.head:
            dz = dg * (c["head_out"] > 0)
            grads["head.w"] = c["head_in"].T @ dz
            grads["head.b"] = dz.sum(axis=0)
            dg = dz @ prm["head.w"].T
        shape = c["gap_shape"]
        dh = np.broadcast_to(dg[:, None, None, :] / (shape[1] * shape[2]), shape)
        for i in range(len(self.spec.blocks()) - 1, -1, -1):
            dh = dh * (c[f"b{i}.out"] > 0)
            dr = conv_back(f"b{i}.c2", dh) * (c[f"b{i}.r1"] > 0)
            dx = conv_back(f"b{i}.c1", dr)
            dx += conv_back(f"b{i}.proj", dh) if f"b{i}.proj.w" in prm else dh
            dh = dx
        conv_back("stem", dh * (c["stem.relu"] > 0), need_dx=False)
        return grads

    # --- ONNX -------------------------------------------------------------------------

    def to_onnx(self, path: str | Path, *, input_name: str = "spectrogram",
                output_name: str = "probabilities", metadata: dict | None = None,
                opset: int = 17) -> Path:
        _, TensorProto, helper, numpy_helper = onnx_builder()
        f32 = np.float32
        inits = [numpy_helper.from_array(np.array(self.x_mean, f32), "x_mean"),
                 numpy_helper.from_array(np.array(self.x_std, f32), "x_std"),
                 numpy_helper.from_array(np.array([1], np.int64), "axis1")]
        nodes = [helper.make_node("Sub", [input_name, "x_mean"], ["xc"]),
                 helper.make_node("Div", ["xc", "x_std"], ["xn"]),
                 helper.make_node("Unsqueeze", ["xn", "axis1"], ["x4"])]

        def conv(name: str, src: str, dst: str, k: int, s: int) -> None:
            w = self.params[name + ".w"]
            cout = w.shape[1]
            cin = w.shape[0] // (k * k)
            wt = w.T.reshape(cout, cin, k, k).astype(f32)
            inits.extend([numpy_helper.from_array(wt, name + ".W"),
                          numpy_helper.from_array(self.params[name + ".b"].astype(f32),
                                                  name + ".B")])
            p = k // 2
            nodes.append(helper.make_node("Conv", [src, name + ".W", name + ".B"], [dst],
                                          kernel_shape=[k, k], strides=[s, s],
                                          pads=[p, p, p, p]))

        conv("stem", "x4", "stem.z", 3, 2)
        nodes.append(helper.make_node("Relu", ["stem.z"], ["h0"]))
        h = "h0"
        for i, (_, _, s) in enumerate(self.spec.blocks()):
            conv(f"b{i}.c1", h, f"b{i}.z1", 3, s)
            nodes.append(helper.make_node("Relu", [f"b{i}.z1"], [f"b{i}.r1"]))
            conv(f"b{i}.c2", f"b{i}.r1", f"b{i}.z2", 3, 1)
            sc = h
            if f"b{i}.proj.w" in self.params:
                conv(f"b{i}.proj", h, f"b{i}.sc", 1, s)
                sc = f"b{i}.sc"
            nodes += [helper.make_node("Add", [f"b{i}.z2", sc], [f"b{i}.sum"]),
                      helper.make_node("Relu", [f"b{i}.sum"], [f"h{i + 1}"])]
            h = f"h{i + 1}"
        nodes += [helper.make_node("GlobalAveragePool", [h], ["gap4"]),
                  helper.make_node("Flatten", ["gap4"], ["gap"], axis=1)]
        g = "gap"
        for name in (["head"] if self.spec.head else []) + ["out"]:
            inits += [numpy_helper.from_array(self.params[name + ".w"].astype(f32),
                                              name + ".W"),
                      numpy_helper.from_array(self.params[name + ".b"].astype(f32),
                                              name + ".B")]
            nodes.append(helper.make_node("Gemm", [g, name + ".W", name + ".B"],
                                          [name + ".z"]))
            g = name + ".z"
            if name == "head":
                nodes.append(helper.make_node("Relu", [g], ["head.r"]))
                g = "head.r"
        nodes.append(helper.make_node("Softmax", [g], [output_name], axis=1))
        sp = self.spec
        graph = helper.make_graph(
            nodes, "fingertip_small_resnet",
            [helper.make_tensor_value_info(input_name, TensorProto.FLOAT,
                                           ["batch", sp.frames, sp.bands])],
            [helper.make_tensor_value_info(output_name, TensorProto.FLOAT,
                                           ["batch", sp.n_classes])], inits)
        meta = {"task": "classification", "classes": json.dumps(self.classes),
                "architecture": json.dumps({"type": "small_resnet",
                                            "channels": list(sp.channels), "head": sp.head,
                                            "frames": sp.frames, "bands": sp.bands}),
                "n_params": str(self.n_params)}
        return save_graph(graph, path, {**meta, **(metadata or {})}, opset)


@dataclass
class CnnTraining:
    epochs: int = 0
    best_epoch: int = 0
    seconds: float = 0.0
    history: list[tuple[float, float]] = field(default_factory=list)
    """(training loss, validation loss) per epoch."""


def train_cnn(x: np.ndarray, y: np.ndarray, *, classes: list[str],
              x_val: np.ndarray | None = None, y_val: np.ndarray | None = None,
              spec: CnnSpec | None = None, epochs: int = 40, batch: int = 32,
              lr: float = 1e-3, weight_decay: float = 1e-4, patience: int = 8,
              min_loss: float = 1e-3, max_seconds: float | None = None, seed: int = 0
              ) -> tuple[SmallResNet, CnnTraining]:
    """Train on windows ``x`` (N, frames, bands) with integer labels ``y``.

    Adam on float32 mini-batches; the weights of the lowest validation loss are kept
    (``x_val``: windows of recordings held out of training; without them, the training
    loss decides). Training stops after ``patience`` epochs without improvement, once the
    validation loss is below ``min_loss`` (converged), or on a ``max_seconds`` budget.
    """
    with blas_threads(1):
        return _train(x, y, classes, x_val, y_val, spec, epochs, batch, lr, weight_decay,
                      patience, min_loss, max_seconds, seed)


def _train(x, y, classes, x_val, y_val, spec, epochs, batch, lr, weight_decay, patience,
           min_loss, max_seconds, seed) -> tuple[SmallResNet, CnnTraining]:
    k = len(classes)
    x, y = check_training(x, y, ndim=3, dtype=np.float32, classes=k,
                          shape="(n, frames, bands)")
    spec = spec or CnnSpec()
    spec = CnnSpec(x.shape[1], x.shape[2], spec.channels, spec.head, k)
    model = SmallResNet.init(spec, seed, classes)
    mean, std = scale(x, axis=None)  # one mean and deviation for every band and frame
    model.x_mean, model.x_std = float(mean), float(std)
    rng = np.random.default_rng(seed)
    names = list(model.params)
    p32 = {n: model.params[n].astype(np.float32) for n in names}
    m = {n: np.zeros_like(p32[n]) for n in names}
    v = {n: np.zeros_like(p32[n]) for n in names}
    b1, b2, eps = 0.9, 0.999, 1e-8
    step = 0
    eye = np.eye(k, dtype=np.float32)
    have_val = x_val is not None and y_val is not None and len(x_val) > 0
    if have_val:
        x_val = np.asarray(x_val, np.float32)
        y_val = np.asarray(y_val, np.int64)

    def loss_of(xs: np.ndarray, ys: np.ndarray) -> float:
        tot = 0.0
        for s in range(0, len(xs), 256):
            pr = model.forward(xs[s:s + 256], np.float32, params=p32)
            tot += float(-np.log(pr[np.arange(len(pr)), ys[s:s + 256]] + 1e-12).sum())
        return tot / len(xs)

    info = CnnTraining()
    best = (math.inf, {n: p.copy() for n, p in p32.items()})
    waited = 0
    t0 = time.perf_counter()
    for epoch in range(epochs):
        order = rng.permutation(len(x))
        tr_loss = 0.0
        for s in range(0, len(order), batch):
            bi = order[s:s + batch]
            cache: dict = {}
            pr = model.forward(x[bi], np.float32, cache=cache, params=p32)
            tr_loss += float(-np.log(pr[np.arange(len(bi)), y[bi]] + 1e-12).sum())
            dlogits = (pr - eye[y[bi]]) / len(bi)
            grads = model.backward(cache, dlogits.astype(np.float32), p32)
            step += 1
            c1, c2 = 1 - b1 ** step, 1 - b2 ** step
            for n in names:
                g = grads[n]
                if n.endswith(".w"):
                    g = g + weight_decay * p32[n]
                m[n] *= b1
                m[n] += (1 - b1) * g
                v[n] *= b2
                v[n] += (1 - b2) * g * g
                p32[n] -= (lr / c1) * m[n] / (np.sqrt(v[n] / c2) + eps)
        tr_loss /= len(x)
        val_loss = loss_of(x_val, y_val) if have_val else tr_loss
        info.history.append((tr_loss, val_loss))
        info.epochs = epoch + 1
        if not math.isfinite(val_loss):
            raise FloatingPointError(f"CNN training diverged at epoch {epoch} (lower lr?)")
        if val_loss < best[0] - 1e-6:
            best = (val_loss, {n: p.copy() for n, p in p32.items()})
            info.best_epoch = epoch + 1
            waited = 0
        else:
            waited += 1
        log.debug("cnn epoch %d: train %.4f val %.4f", epoch + 1, tr_loss, val_loss)
        if waited >= patience or val_loss < min_loss:
            break
        if max_seconds is not None and time.perf_counter() - t0 > max_seconds:
            log.info("CNN training stopped by its time budget after %d epochs", epoch + 1)
            break
    model.params = {n: p.astype(np.float64) for n, p in best[1].items()}
    info.seconds = time.perf_counter() - t0
    return model, info
