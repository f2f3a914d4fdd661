"""The candidate maps counts -> (Fx, Fy), their fitting and their ONNX graphs: affine (SVD
with a conditioning check), polynomials (ridge), MLPs, all on standardised inputs."""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import combinations_with_replacement
from pathlib import Path

import numpy as np

from ...nets.mlp import MLP, to_onnx, train_mlp
from ...nets.onnx_io import batch_graph, onnx_builder, save_graph
from ...nets.standardise import constant_features, standardise
from .checks import _dependence
from .errors import DeadChannelError, IllConditionedError
from .limits import CHANNELS, MAX_CONDITION

DEFAULT_MODELS = ("affine", "poly2", "poly3", "mlp8", "mlp16x16", "mlp32x32")
MODEL_GROUPS = {"poly": ("poly2", "poly3"), "mlp": ("mlp8", "mlp16x16", "mlp32x32"),
                "all": DEFAULT_MODELS}


RIDGE_GRID = (0.0, 1e-10, 1e-8, 1e-6, 1e-4, 1e-2)
"""Ridge strengths tried for the polynomials, relative to the mean squared feature."""


def poly_terms(degree: int, channels: int = CHANNELS) -> list[tuple[int, ...]]:
    """Monomials of the standardised channels, degree 1..``degree``, in feature order."""
    return [t for k in range(1, degree + 1)
            for t in combinations_with_replacement(range(channels), k)]


@dataclass
class LinearFeatureMap:
    """F = phi(w) @ coef + intercept with w = ((counts - x_mean) / x_std) @ rotation and phi
    the monomials of w up to ``degree``. Affine: degree 1, no rotation. Polynomials: the
    rotation whitens (principal components of the standardised counts, unit variance), so
    that the monomials are not nearly collinear (opposite gauges read nearly opposite
    signals) and the coefficients stay small enough for float32 inference."""

    name: str
    degree: int
    x_mean: np.ndarray
    x_std: np.ndarray
    coef: np.ndarray
    intercept: np.ndarray
    ridge: float = 0.0
    condition: float = math.nan
    rotation: np.ndarray | None = None

    @property
    def kind(self) -> str:
        return "affine" if self.degree == 1 else "poly"

    @property
    def terms(self) -> list[tuple[int, ...]]:
        return poly_terms(self.degree, len(self.x_mean))

    @property
    def n_params(self) -> int:
        return int(self.coef.size + self.intercept.size)

    def features(self, counts: np.ndarray) -> np.ndarray:
        z = (np.asarray(counts, np.float64) - self.x_mean) / self.x_std
        if self.rotation is not None:
            z = z @ self.rotation
        return _monomials(z, self.terms)

    def predict(self, counts: np.ndarray) -> np.ndarray:
        """Float64 reference: (N, 2) forces in N."""
        return self.features(counts) @ self.coef + self.intercept

    def to_onnx(self, path: str | Path, metadata: dict | None = None) -> Path:
        return _linear_map_onnx(self, path, metadata or {})


def _monomials(z: np.ndarray, terms: Sequence[tuple[int, ...]]) -> np.ndarray:
    out = np.empty((z.shape[0], len(terms)))
    for k, t in enumerate(terms):
        v = z[:, t[0]]
        for c in t[1:]:
            v = v * z[:, c]
        out[:, k] = v
    return out


def _standardise(counts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    dead = constant_features(counts)
    if len(dead):
        raise DeadChannelError(f"channel(s) {dead.tolist()} are constant")
    return standardise(counts)


def whitening(z: np.ndarray) -> np.ndarray:
    """Matrix p such that z @ p has uncorrelated unit-variance columns (PCA whitening of
    centred ``z``); components with no variance are left unscaled."""
    _, s, vt = np.linalg.svd(z - z.mean(axis=0), full_matrices=False)
    s = np.maximum(s, s[0] * 1e-9)
    return vt.T / s * math.sqrt(len(z))


def fit_affine(counts: np.ndarray, force: np.ndarray, *, max_condition: float = MAX_CONDITION,
               name: str = "affine") -> LinearFeatureMap:
    """Least squares on standardised channels, solved by SVD; refuses (raises
    :class:`IllConditionedError`) when the condition number exceeds ``max_condition``."""
    z, mean, sd = _standardise(counts)
    y = np.asarray(force, np.float64)
    a = np.column_stack([z, np.ones(len(z))])
    u, s, vt = np.linalg.svd(a, full_matrices=False)
    cond = float(s[0] / s[-1]) if s[-1] > 0 else math.inf
    if not cond <= max_condition:
        raise IllConditionedError(
            f"the standardised channels are ill-conditioned (condition number {cond:.3g} > "
            f"{max_condition:.3g}): {_dependence(vt[-1][:CHANNELS])}")
    w = vt.T @ ((u.T @ y) / s[:, None])
    return LinearFeatureMap(name, 1, mean, sd, w[:-1], w[-1], 0.0, cond)


def _ridge_solutions(p: np.ndarray, y: np.ndarray, lams: Sequence[float]):
    """Ridge on centred features (the intercept is not penalised), every lambda at once;
    lambdas are relative to the mean squared (centred) feature. Solved through the
    eigenvectors of the small Gram matrix (the whitened monomials are well conditioned)."""
    pm, ym = p.mean(axis=0), y.mean(axis=0)
    pc, yc = p - pm, y - ym
    e, v = np.linalg.eigh(pc.T @ pc)
    e = np.maximum(e, 0.0)
    scale = float(np.mean(e)) if len(e) else 1.0
    vty = v.T @ (pc.T @ yc)
    out = []
    for lam in lams:
        d = 1 / (e + lam * scale) if lam > 0 else \
            np.where(e > e.max() * 1e-13, 1 / np.maximum(e, 1e-300), 0.0)
        w = v @ (d[:, None] * vty)
        out.append((w, ym - pm @ w))
    return out


def fit_poly(counts: np.ndarray, force: np.ndarray, degree: int, *,
             groups: np.ndarray | None = None, ridge: float | None = None,
             name: str | None = None) -> LinearFeatureMap:
    """Polynomial of the standardised channels with ridge; ``ridge`` None picks it from
    :data:`RIDGE_GRID` by 3-fold cross-validation over ``groups`` (whole groups per fold)."""
    if degree < 1:
        raise ValueError("degree must be at least 1")
    z, mean, sd = _standardise(counts)
    y = np.asarray(force, np.float64)
    terms = poly_terms(degree)
    rot = whitening(z) if degree > 1 else None
    p = _monomials(z if rot is None else z @ rot, terms)
    if ridge is None:
        g = np.arange(len(z)) // max(1, len(z) // 12) if groups is None else groups
        uniq = np.unique(g)
        order = np.random.default_rng(7).permutation(len(uniq))
        err = np.zeros(len(RIDGE_GRID))
        for k in range(3):
            te = np.isin(g, uniq[order[k::3]])
            if te.all() or not te.any():
                continue
            for j, (w, b) in enumerate(_ridge_solutions(p[~te], y[~te], RIDGE_GRID)):
                err[j] += float(np.sum((p[te] @ w + b - y[te]) ** 2))
        ridge = float(RIDGE_GRID[int(np.argmin(err))])
    w, b = _ridge_solutions(p, y, [ridge])[0]
    pa = np.column_stack([p, np.ones(len(p))])
    ev = np.linalg.eigvalsh(pa.T @ pa)
    cond = float(math.sqrt(ev[-1] / ev[0])) if ev[0] > 0 else math.inf
    return LinearFeatureMap(name or f"poly{degree}", degree, mean, sd, w, b, ridge, cond, rot)


@dataclass
class MLPMap:
    """An MLP from :mod:`~fingertip.models.nets.mlp` (its own normalisation) as a force map."""

    name: str
    mlp: MLP
    kind: str = "mlp"

    @property
    def n_params(self) -> int:
        return self.mlp.n_params

    def predict(self, counts: np.ndarray) -> np.ndarray:
        return self.mlp.forward(counts)

    def to_onnx(self, path: str | Path, metadata: dict | None = None) -> Path:
        return to_onnx(self.mlp, path, input_name="counts", output_name="force",
                       metadata=metadata)


def mlp_hidden(name: str) -> tuple[int, ...]:
    """``mlp16x16`` -> (16, 16)."""
    try:
        sizes = tuple(int(s) for s in name[3:].split("x"))
    except ValueError:
        sizes = ()
    if not name.startswith("mlp") or not sizes or min(sizes) < 1 or max(sizes) > 4096:
        raise ValueError(f"bad MLP name {name!r}: use mlpN or mlpNxM (hidden layer sizes)")
    return sizes


def fit_mlp(counts: np.ndarray, force: np.ndarray, hidden: tuple[int, ...], *,
            epochs: int = 1500, seed: int = 0, whiten: bool = True,
            weight_decay: float = 1e-4, name: str | None = None) -> MLPMap:
    """Train with Adam (batch 128, lr 5e-3, L2 ``weight_decay``, early stopping with
    patience epochs/10) on whitened channels: the principal components of the standardised
    counts, each scaled to unit variance. Opposite gauges read nearly opposite signals, so
    what tells contact heights apart hides in small components that plain standardisation
    leaves tiny (whitening: about 0.15 N instead of 0.2 N held out on the virtual units).
    The whitening is folded into the first layer, so the result is a plain
    :class:`~fingertip.models.nets.mlp.MLP` whose ONNX graph standardises the raw counts."""
    z, mean, sd = _standardise(counts)
    p = whitening(z) if whiten else np.eye(z.shape[1])
    m = train_mlp(z @ p, force, hidden=hidden, epochs=epochs, batch=128, lr=5e-3,
                  weight_decay=weight_decay, patience=max(20, epochs // 10), seed=seed)
    # Fold: ((z @ p - m_w) / s_w) @ W1 + b1 == z @ W1' + b1', and z = (counts - mean) / sd.
    w1 = (p / m.x_std) @ m.weights[0]
    b1 = m.biases[0] - (m.x_mean / m.x_std) @ m.weights[0]
    folded = MLP([w1, *m.weights[1:]], [b1, *m.biases[1:]], mean, sd, m.task, m.y_offset,
                 m.y_scale, m.classes)
    return MLPMap(name or "mlp" + "x".join(str(h) for h in hidden), folded)


def expand_models(spec: str | Sequence[str]) -> list[str]:
    """``"affine,poly,mlp"`` -> model names; groups: poly, mlp, all; names: affine, polyN
    (N 1-4), mlpN[xM...]."""
    items = spec.split(",") if isinstance(spec, str) else list(spec)
    out: list[str] = []
    for it in (s.strip().lower() for s in items):
        if not it:
            continue
        names = MODEL_GROUPS.get(it, (it,))
        for n in names:
            if n == "affine":
                pass
            elif n.startswith("poly"):
                if n[4:] not in ("1", "2", "3", "4"):
                    raise ValueError(f"bad polynomial {n!r}: poly2, poly3 (or poly1, poly4)")
            elif n.startswith("mlp"):
                mlp_hidden(n)
            else:
                raise ValueError(f"unknown model {n!r}: affine, poly (poly2, poly3), "
                                 f"mlp (mlp8, mlp16x16, mlp32x32), or mlpNxM")
            if n not in out:
                out.append(n)
    if not out:
        raise ValueError("no models to fit")
    return out


def fit_model(name: str, counts: np.ndarray, force: np.ndarray, *,
              groups: np.ndarray | None = None, epochs: int = 1500, seed: int = 0,
              max_condition: float = MAX_CONDITION):
    if name == "affine":
        return fit_affine(counts, force, max_condition=max_condition)
    if name.startswith("poly"):
        return fit_poly(counts, force, int(name[4:]), groups=groups)
    return fit_mlp(counts, force, mlp_hidden(name), epochs=epochs, seed=seed, name=name)


def _linear_map_onnx(m: LinearFeatureMap, path: str | Path, metadata: dict,
                     opset: int = 17) -> Path:
    _, _, helper, numpy_helper = onnx_builder()
    f32 = np.float32
    d = len(m.x_mean)
    inits = [numpy_helper.from_array(m.x_mean.astype(f32), "x_mean"),
             numpy_helper.from_array(m.x_std.astype(f32), "x_std"),
             numpy_helper.from_array(m.coef.astype(f32), "coef"),
             numpy_helper.from_array(m.intercept.astype(f32), "intercept")]
    nodes = [helper.make_node("Sub", ["counts", "x_mean"], ["xc"]),
             helper.make_node("Div", ["xc", "x_std"], ["zs" if m.rotation is not None
                                                       else "z"])]
    if m.rotation is not None:
        inits.append(numpy_helper.from_array(m.rotation.astype(f32), "rotation"))
        nodes.append(helper.make_node("MatMul", ["zs", "rotation"], ["z"]))
    # Monomials as outer products: q_k = vec(q_{k-1} (x) z), then one MatMul with the
    # coefficients at the positions of the sorted index tuples (zeros elsewhere).
    terms = m.terms
    full = np.zeros((sum(d ** k for k in range(1, m.degree + 1)), 2))
    offset = {k: sum(d ** j for j in range(1, k)) for k in range(1, m.degree + 1)}
    for t, c in zip(terms, m.coef, strict=True):
        pos = 0
        for i in t:
            pos = pos * d + i
        full[offset[len(t)] + pos] = c
    inits[2] = numpy_helper.from_array(full.astype(f32), "coef")
    feats = ["z"]
    if m.degree > 1:
        inits += [numpy_helper.from_array(np.array([2], np.int64), "ax2"),
                  numpy_helper.from_array(np.array([1], np.int64), "ax1"),
                  numpy_helper.from_array(np.array([0, -1], np.int64), "flat")]
        nodes.append(helper.make_node("Unsqueeze", ["z", "ax1"], ["z_row"]))
    prev = "z"
    for k in range(2, m.degree + 1):
        nodes += [helper.make_node("Unsqueeze", [prev, "ax2"], [f"col{k}"]),
                  helper.make_node("Mul", [f"col{k}", "z_row"], [f"outer{k}"]),
                  helper.make_node("Reshape", [f"outer{k}", "flat"], [f"q{k}"])]
        prev = f"q{k}"
        feats.append(prev)
    if len(feats) > 1:
        nodes.append(helper.make_node("Concat", feats, ["phi"], axis=1))
        phi = "phi"
    else:
        phi = "z"
    nodes += [helper.make_node("MatMul", [phi, "coef"], ["lin"]),
              helper.make_node("Add", ["lin", "intercept"], ["force"])]
    graph = batch_graph(nodes, f"fingertip_force_{m.name}", ("counts", d), ("force", 2),
                        inits)
    return save_graph(graph, path, metadata, opset)
