"""The models the material trainer chooses from, cheapest first, and how each is fitted.

:func:`candidates` lists them for a :class:`~.setup.Setup`: the plain log-spectrum
mean-and-deviation with logistic regression (``baseline``), logistic regression on the
adapted log bands (``linear``), an MLP on the same (``mlp``), the three views combined
(``ensemble``, :mod:`.ensemble`), an RBF-kernel SVM and boosted trees on the log bands'
mean, deviation and 90th percentile (``svm``, ``boost``, :mod:`.spectral`) and a small CNN
(``cnn``, whose fixed spectrogram windows slide and are averaged). All but the CNN are
growing-window models (:mod:`.anytime`) and read columns of one shared set of features
(:mod:`.bank`): their :attr:`Candidate.cols`. The ensemble is a composite: its members are
the baseline's, the linear candidate's and the MLP's models (and a second MLP), fitted once
per fold and shared (:mod:`.cross_validation`).

A fit returns a plain model (:class:`~fingertip.models.nets.linear.Logistic`, an MLP, ...)
that a worker process can send back; :func:`as_fitted` gives it its float64 forward pass
and its ONNX export.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from .classify import FeaturePipeline, WindowSpec
from .features import FeatureConfig
from .setup import Setup

CANDIDATES = ("baseline", "linear", "mlp", "ensemble", "svm", "boost", "cnn")
"""Cheapest first (per answer, then to train): of candidates tied on accuracy, the first
wins, so a costlier one must beat a cheaper one by more than :data:`TIE`."""
DEFAULT_CANDIDATES = tuple(n for n in CANDIDATES if n != "boost")
"""What the trainer compares unless told otherwise. Boosted trees are opt-in (``--models
...,boost``): their cross-validation took 345-553 s on the bench's sets in the forked fold
workers (2.5 s of CPU per fit alone), several times every other candidate together, and they
won on none of those sets."""
ENSEMBLE_MLPS = 2
"""MLPs in the ensemble candidate (seeds differ)."""
ENSEMBLE_SEED_STEP = 1000
CNN_EPOCHS = 30
CNN_WORK_LIMIT = 250_000
"""The CNN candidate is cross-validated only when its projected work, in window-epochs
(training windows of every recording x :data:`CNN_EPOCHS` x fits: the folds and the final
model; :func:`~.cross_validation.cnn_work`), is at most this. The rule counts, it does not
time: the same folder always gives the same candidates, on any machine and at any load. The
limit is about a minute of the numpy CNN's training at the rate measured on the project's
VM (225 us per window-epoch, one thread, load average 4: docs/classifiers.md)."""
TIE = 0.005
"""Mean accuracies (over the decision times) this close are the same within the
cross-validation's noise: candidates within it of the best are tied and the cheapest wins;
a robustness (augmentation, the mains notch) that costs no more than it is taken."""
BANK_STATS = ("mean", "std", "flux", "p90")
"""The statistics of the shared features (:mod:`.bank`), in this order: the first three
over every column (the ensemble reads them all), the last over the log bands only."""

Fit = Callable[[np.ndarray, np.ndarray, np.ndarray, list[str], int], Any]
"""(inputs, labels, recording of each row, classes, seed) -> a plain model."""


@dataclass
class Fitted:
    """A trained candidate: probabilities (float64 reference) and its ONNX export."""

    forward: Callable[[np.ndarray], np.ndarray]
    n_params: int
    export: Callable[[Path, float, dict], Path]
    """(path, temperature, metadata) -> path of the ONNX graph."""
    model: object = None


@dataclass
class Candidate:
    name: str
    about: str
    pipe: FeaturePipeline
    """The features it runs on (what the exported model's metadata describes)."""
    fit: Fit
    cols: np.ndarray | None = None
    """Its columns of the shared features (:mod:`.bank`); None: computed on its own (the
    CNN's spectrogram windows)."""
    members: tuple[tuple[Candidate, int], ...] = ()
    """A composite's parts: (candidate, seed offset), combined by :mod:`.ensemble`."""
    prepare_first: bool = False
    """Its first fit fixes a choice the next fits reuse (the L2 penalty): it runs alone,
    before the other folds run in parallel."""
    last: Fitted | None = None
    """The model of the last cross-validation fold (for costs)."""
    last_fit_s: float = 0.0
    fit_s: list[float] = field(default_factory=list)
    """Seconds of each fit of its cross-validation (members' shared fits count once, in
    the member's own candidate)."""

    @property
    def first_alone(self) -> bool:
        """Its next fit must run alone, before the others: it fixes a choice they reuse
        (once made, as in a trial after the candidate's own cross-validation, it need not)."""
        return self.prepare_first and getattr(self.fit, "l2", None) is None

    def train(self, x: np.ndarray, y: np.ndarray, g: np.ndarray, classes: list[str],
              seed: int) -> Fitted:
        """Fit on rows ``x`` (this candidate's columns already) and wrap the model."""
        if self.members:
            return as_fitted(self.combine([m.fit(x[:, _local(self, m)], y, g, classes,
                                                  seed + off) for m, off in self.members],
                                          classes))
        return as_fitted(self.fit(x, y, g, classes, seed))

    def combine(self, models: Sequence[Any], classes: list[str]) -> Any:
        """The composite of its members' fitted ``models`` (in :attr:`members` order)."""
        from .ensemble import Ensemble, Member

        return Ensemble([Member(m, _local(self, c)) for m, (c, _) in
                         zip(models, self.members, strict=True)], len(self.cols),
                        list(classes))


def _local(composite: Candidate, member: Candidate) -> np.ndarray:
    """The member's columns within the composite's inputs."""
    where = {int(c): i for i, c in enumerate(composite.cols)}
    return np.array([where[int(c)] for c in member.cols], np.intp)


def as_fitted(model: Any) -> Fitted:
    """The float64 forward pass and the ONNX export of a fitted model of any kind."""
    from ..nets.linear import Logistic
    from ..nets.mlp import MLP
    from .ensemble import Ensemble
    from .spectral import SpectralModel

    if isinstance(model, Logistic):
        from ..nets.linear import to_onnx as lin_onnx

        return Fitted(model.forward, model.n_params, lambda path, t, meta: lin_onnx(
            model, path, temperature=t, metadata=meta), model)
    if isinstance(model, MLP):
        from ..nets.mlp import to_onnx as mlp_onnx

        def export(path, t, meta):
            cooled = replace(model, weights=[*model.weights[:-1], model.weights[-1] / t],
                             biases=[*model.biases[:-1], model.biases[-1] / t])
            return mlp_onnx(cooled, path, metadata=meta)

        return Fitted(model.forward, model.n_params, export, model)
    if isinstance(model, Ensemble):
        from .ensemble import to_onnx as ens_onnx

        return Fitted(model.forward, model.n_params, lambda path, t, meta: ens_onnx(
            model, path, temperature=t, metadata=meta), model)
    if isinstance(model, SpectralModel):
        from .spectral import to_onnx as sk_onnx

        return Fitted(model.forward, model.n_params, lambda path, t, meta: sk_onnx(
            model, path, temperature=t, metadata=meta), model)

    def cnn_export(path, t, meta):  # the CNN of :mod:`..nets.cnn`
        p = dict(model.params, **{"out.w": model.params["out.w"] / t,
                                  "out.b": model.params["out.b"] / t})
        return replace(model, params=p).to_onnx(path, metadata=meta)

    return Fitted(model.forward, model.n_params, cnn_export, model)


class LinearFit:
    """Logistic regression whose L2 penalty is chosen (inner split) at the first fit and
    kept for the next ones (the other folds, the trials and the final model): choosing
    costs four fits. The next fits also start from the first fit's weights (about a
    quarter fewer L-BFGS steps on the bench's textures). Only the first fit sets this
    state, so every later fit starts from the same point whatever process runs it. A
    class, not a closure, so that a worker process receives its state."""

    def __init__(self) -> None:
        self.l2: float | None = None
        self.first = None

    def __call__(self, x, y, g, classes, seed):
        from ..nets.cnn import blas_threads
        from ..nets.linear import train_logistic

        with blas_threads(1):  # L-BFGS's small products: threads only contend on 2 cores
            m = train_logistic(x, y, classes=classes, groups=g, seed=seed, l2=self.l2,
                               start=self.first)
        self.keep(m)
        return m

    def keep(self, m) -> None:
        """Take the choices of ``m`` when it is the first fit (made elsewhere: in a worker
        process)."""
        if self.l2 is None:
            self.l2, self.first = m.l2, m


MLP_PATIENCE = 15
"""Epochs without a better validation loss before an MLP stops (it keeps its best
weights). The default 30 of :func:`~..nets.mlp.train_mlp` gave the same accuracy on two
folds each of the bench's 1,000 slides of 1 s and 30 textures (the best epoch came
earlier) for a third more CPU."""


@dataclass
class MlpFit:
    hidden: tuple[int, ...]
    epochs: int

    def __call__(self, x, y, g, classes, seed):
        from ..nets.cnn import blas_threads
        from ..nets.mlp import train_mlp

        with blas_threads(1):
            return train_mlp(x, y, hidden=self.hidden, task="classification",
                             classes=classes, epochs=self.epochs, seed=seed,
                             patience=MLP_PATIENCE)


@dataclass
class SpectralFit:
    kind: str
    """``svm`` or ``boost`` (:mod:`.spectral`)."""

    def __call__(self, x, y, g, classes, seed):
        import sklearn.ensemble  # noqa: F401  (loads OpenMP before the limit is set)
        import sklearn.svm  # noqa: F401
        from threadpoolctl import threadpool_limits

        from .spectral import train_boost, train_svm

        # One thread: the folds already fill the cores. threadpoolctl limits only the
        # libraries loaded when it is entered, so scikit-learn's OpenMP must be loaded
        # first: entered before, the limit missed it, and in the forked fold workers each
        # boosted-trees fit spun OpenMP threads on every core (40 s of CPU against 7 s in
        # one thread, 345-553 s of wall time per cross-validation on the bench's sets).
        with threadpool_limits(1):
            return (train_svm if self.kind == "svm" else train_boost)(x, y, g, classes, seed)


@dataclass
class CnnFit:
    """The small ResNet of :mod:`..nets.cnn` on fixed spectrogram windows, early-stopped
    on 15 % of the training *recordings* (at least one), each fit capped at
    ``max_seconds``."""

    epochs: int
    max_seconds: float | None

    def __call__(self, x, y, g, classes, seed):
        from ..nets.cnn import train_cnn

        rng = np.random.default_rng(seed)
        groups = np.unique(g)
        val = np.isin(g, rng.choice(groups, max(1, round(0.15 * len(groups))),
                                    replace=False))
        if val.all() or len(np.unique(y[~val])) < len(classes):
            val[:] = False  # too few recordings to hold some out: the training loss decides
        m, _ = train_cnn(x[~val], y[~val], classes=classes, x_val=x[val], y_val=y[val],
                         epochs=self.epochs, patience=5, max_seconds=self.max_seconds,
                         seed=seed)
        return m


def baseline_bins(cfg: FeatureConfig) -> int:
    """Linear bins of the baseline's plain log spectrum: one per FFT bin (1 / window
    length apart) over the band range, 4 to 256."""
    return int(min(256, max(4, (cfg.f_hi - cfg.f_lo) / (1.0 / cfg.win_s))))


def bank_config(cfg: FeatureConfig) -> FeatureConfig:
    """The shared features' bands: the log bands, then the baseline's linear bins."""
    return replace(cfg, linear_bins=baseline_bins(cfg))


def bank_columns(cfg: FeatureConfig, stats: Sequence[str], linear: bool = False
                 ) -> np.ndarray:
    """Columns of the shared features (:func:`bank_config`, :data:`BANK_STATS`) holding
    ``stats`` of the log bands (``linear``: of the linear bins)."""
    nb, total = cfg.n_bands, cfg.n_bands + baseline_bins(cfg)
    lo, hi = (nb, total) if linear else (0, nb)
    if linear and BANK_STATS[-1] in stats:
        raise ValueError(f"the shared {BANK_STATS[-1]} covers the log bands only")
    return np.concatenate([np.arange(lo, hi) + BANK_STATS.index(s) * total for s in stats])


def candidates(setup: Setup, names: Sequence[str] = CANDIDATES,
               hidden: tuple[int, ...] = (64,), epochs: int = 300,
               cnn_epochs: int = CNN_EPOCHS, cnn_max_seconds: float | None = None
               ) -> list[Candidate]:
    """The candidates ``names`` (in :data:`CANDIDATES` order) for ``setup``."""
    bad = [n for n in names if n not in CANDIDATES]
    if bad:
        raise ValueError(f"unknown candidate {bad[0]!r} (one of {CANDIDATES})")
    cfg = setup.cfg
    n = baseline_bins(cfg)
    made: dict[str, Candidate] = {}

    def make(name: str) -> Candidate:
        if name in made:
            return made[name]
        if name == "baseline":
            c = Candidate(name, f"log spectrum ({n} linear bins of {1.0 / cfg.win_s:.3g} Hz), "
                                "mean and deviation over time, logistic regression",
                          FeaturePipeline(replace(cfg, scale="linear", n_bands=n),
                                          setup.spec(("mean", "std"))), LinearFit(),
                          bank_columns(cfg, ("mean", "std"), linear=True), prepare_first=True)
        elif name == "linear":
            c = Candidate(name, f"{cfg.n_bands} log bands, mean and deviation over time, "
                                "logistic regression",
                          FeaturePipeline(cfg, setup.spec(("mean", "std"))), LinearFit(),
                          bank_columns(cfg, ("mean", "std")), prepare_first=True)
        elif name == "mlp":
            c = Candidate(name, f"{cfg.n_bands} log bands, mean, deviation and "
                                f"frame-to-frame change, MLP {list(hidden)}",
                          FeaturePipeline(cfg, setup.spec(("mean", "std", "flux"))),
                          MlpFit(hidden, epochs), bank_columns(cfg, ("mean", "std", "flux")))
        elif name in ("svm", "boost"):
            what = ("RBF-kernel SVM" if name == "svm" else
                    "boosted trees (histogram gradient boosting)")
            c = Candidate(name, f"{cfg.n_bands} log bands, mean, deviation and 90th "
                                f"percentile over time, {what}",
                          FeaturePipeline(cfg, setup.spec(("mean", "std", "p90"))),
                          SpectralFit(name), bank_columns(cfg, ("mean", "std", "p90")))
        elif name == "ensemble":
            c = Candidate(name, f"geometric mean of logistic regressions on {n} linear bins "
                                f"and on {cfg.n_bands} log bands (mean, deviation) and "
                                f"{ENSEMBLE_MLPS} MLPs {list(hidden)} on the log bands (and "
                                "frame-to-frame change)",
                          FeaturePipeline(bank_config(cfg),
                                          setup.spec(("mean", "std", "flux"))), _no_fit,
                          np.arange(3 * (cfg.n_bands + n)))
            c.members = ((make("baseline"), 0), (make("linear"), 0),
                         *((make("mlp"), ENSEMBLE_SEED_STEP * j)
                           for j in range(ENSEMBLE_MLPS)))
        else:  # cnn
            f = setup.frames(setup.first_s)
            c = Candidate(name, f"small ResNet on {f}-frame log-band spectrograms "
                                f"({setup.first_s:g} s) sliding every {setup.step_s:g} s, "
                                "answers averaged",
                          FeaturePipeline(cfg, WindowSpec(f, setup.step_s, "spectrogram")),
                          CnnFit(cnn_epochs, cnn_max_seconds))
        made[name] = c
        return c

    return [make(name) for name in CANDIDATES if name in names]


def _no_fit(*_: object) -> Any:
    raise TypeError("a composite candidate is fitted through its members")
