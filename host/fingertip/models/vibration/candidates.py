"""The material trainer's choices: features and windows adapted to the data, candidate
models, and their cross-validated anytime answers.

:func:`choose_setup` reads the recordings' rates and lengths and decides the band range,
the first and the longest window and the prediction step, with the reason for each (a
folder of 1 s slides at 2.2 kHz and one of 0.3 s knocks at 44.1 kHz both train without
options). :func:`candidates` lists the models the cross-validation chooses from: the plain
log-spectrum mean-and-deviation with logistic regression (``baseline``), logistic
regression on the adapted log bands (``linear``), an MLP on the same (``mlp``), the three
views combined (``ensemble``, :mod:`.ensemble`) and a small CNN (``cnn``, whose fixed
spectrogram windows slide and are averaged). The others are
growing-window models (:mod:`.anytime`): one answer every step, summarising everything
heard so far. :func:`cross_validate` gives every recording's out-of-fold running
probabilities; :func:`anytime_scores` turns them into accuracy at each decision time,
time to decision, calibration and cost.
"""
from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from .augment import NONE as NO_AUGMENT
from .augment import AugmentConfig, augmented
from .anytime import DECISION_TIMES, at_time, running, time_label
from .classify import (
    Dataset,
    DatasetError,
    FeaturePipeline,
    Windows,
    WindowSpec,
    stratified_folds,
)
from .features import CANONICAL_RATE, FeatureConfig, Recording
from .reliability import Novelty, apply_temperature, ece, fit_temperature

log = logging.getLogger(__name__)

CANDIDATES = ("baseline", "linear", "mlp", "ensemble", "cnn")
"""Cheapest first: of candidates tied on accuracy, the first wins."""
ENSEMBLE_MLPS = 2
"""MLPs in the ensemble candidate (seeds differ)."""
CNN_EPOCHS = 30
CNN_WORK_LIMIT = 250_000
"""The CNN candidate is cross-validated only when its projected work, in window-epochs
(training windows of every recording x :data:`CNN_EPOCHS` x fits: the folds and the final
model; :func:`cnn_work`), is at most this. The rule counts, it does not time: the same
folder always gives the same candidates, on any machine and at any load. The limit is
about a minute of the numpy CNN's training at the rate measured on the project's VM (225 us
per window-epoch, one thread, load average 4: docs/classifiers.md), half the trainer's
120 s goal for 700 slides of 2 s."""
TIE = 0.005
"""Mean accuracies (over the decision times) this close are the same within the
cross-validation's noise: candidates within it of the best are tied and the cheapest wins;
a robustness (augmentation, the mains notch) that costs no more than it is taken."""
LONGEST_S = 2.0
"""The longest window: beyond it, windows slide and their answers are averaged."""
FIRST_S = 0.25
STEP_S = 0.1
THRESHOLDS = (0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 0.98, 0.99, 0.995, 0.999)
TARGET_ACCURACY = 0.95
UNKNOWN_KEEP = 0.95
"""Share of known recordings (out of fold) whose answer must stay a class, not unknown."""
LASTED_TOL_S = 0.05
"""A recording whose last window ends this close to a decision time counts as lasting
that long (frames cannot reach the very last samples: a 1 s recording's last frame ends
at 0.997 s)."""


@dataclass
class Setup:
    """Features and windows chosen for a dataset, and why."""

    cfg: FeatureConfig
    first_s: float
    longest_s: float
    step_s: float
    reasons: dict[str, str] = field(default_factory=dict)

    def frames(self, seconds: float) -> int:
        """Frames of a window whose audio spans ``seconds`` (at least 2)."""
        return max(2, int((seconds - self.cfg.win_s) / self.cfg.hop_s + 1e-6) + 1)

    def spec(self, stats: Sequence[str]) -> WindowSpec:
        return WindowSpec(self.frames(self.longest_s), self.step_s, "growing",
                          self.frames(self.first_s), tuple(stats))

    def to_dict(self) -> dict:
        return {"features": self.cfg.to_dict(), "first_window_s": self.first_s,
                "longest_window_s": self.longest_s, "step_s": self.step_s,
                "why": self.reasons}


def choose_setup(ds: Dataset, features: FeatureConfig | None = None,
                 max_hz: float | None = None, window_s: float | None = None,
                 step_s: float | None = None) -> Setup:
    """Bands, windows and step for the recordings of ``ds`` (arguments that are given win).

    - bands: top at 0.9 x the lowest rate's Nyquist (at most 7.2 kHz); bottom six octaves
      below it, between 30 and 100 Hz (low rates keep their low frequencies, where slow
      textures live; high rates stay above mains hum);
    - longest window: the median recording's length, at most 2 s (a slide's spectrum is
      then estimated from all of it; longer recordings average 2 s windows);
    - first window: 0.25 s, or half the shortest recording when that is shorter (a 0.3 s
      knock gets a first answer at 0.15 s); at least 3 frames;
    - step: 0.1 s (10 Hz answers), or a tenth of the median length for short recordings.
    """
    base = features or FeatureConfig()
    cfg = base.for_rates(ds.rates, max_hz)
    reasons = {"f_hi": f"{cfg.f_hi:g} Hz: 0.9 x the Nyquist frequency of the lowest rate "
                       f"({min(ds.rates):g} Hz), at most {base.top_for_rate(1e9):g} Hz"}
    if features is None or features.f_lo == FeatureConfig().f_lo:
        f_lo = float(min(100.0, max(30.0, cfg.f_hi / 72)))
        cfg = replace(cfg, f_lo=round(f_lo, 1))
        reasons["f_lo"] = (f"{cfg.f_lo:g} Hz: six octaves below the top, kept within "
                           "30-100 Hz (above mains hum when the band allows)")
    durations = np.array([it.rec.duration for it in ds.items])
    med, shortest = float(np.median(durations)), float(durations.min())
    min_span = cfg.win_s + 2 * cfg.hop_s
    if window_s is None:
        longest = min(LONGEST_S, med)
        reasons["longest_window"] = (f"{longest:.3g} s: the median recording lasts "
                                     f"{med:.3g} s (windows never exceed {LONGEST_S:g} s; "
                                     "longer recordings average sliding windows)")
    else:
        longest = float(window_s)
        reasons["longest_window"] = f"{longest:.3g} s: given"
    longest = max(longest, min_span)
    first = min(FIRST_S, max(min_span, shortest / 2), longest)
    reasons["first_window"] = (f"{first:.3g} s: the first answer ({FIRST_S:g} s, or half of "
                               f"the shortest recording, {shortest:.3g} s)")
    if step_s is None:
        step = min(STEP_S, max(cfg.hop_s, med / 10))
        reasons["step"] = f"{step:.3g} s between answers ({STEP_S:g} s, or a tenth of the " \
                          "median recording for short ones)"
    else:
        step = float(step_s)
        reasons["step"] = f"{step:.3g} s: given"
    return Setup(cfg, round(first, 4), round(longest, 4), round(step, 4), reasons)


# --- candidate models -----------------------------------------------------------------------

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
    train: Callable[[np.ndarray, np.ndarray, np.ndarray, list[str], int], Fitted]
    last: Fitted | None = None
    """The model of the last cross-validation fold (for costs)."""
    last_fit_s: float = 0.0


def _linear_trainer():
    """Logistic regression whose L2 penalty is chosen (inner split) at the first fit and
    kept for the next ones (the other folds and the final model): choosing costs four fits."""
    state: dict[str, float | None] = {"l2": None}

    def train(x, y, g, classes, seed) -> Fitted:
        from ..nets.cnn import blas_threads
        from ..nets.linear import to_onnx, train_logistic

        with blas_threads(1):  # L-BFGS's small products: threads only contend on 2 cores
            m = train_logistic(x, y, classes=classes, groups=g, seed=seed, l2=state["l2"])
        state["l2"] = m.l2
        return Fitted(m.forward, m.n_params,
                      lambda path, t, meta: to_onnx(m, path, temperature=t, metadata=meta),
                      m)
    return train


def _mlp_trainer(hidden: tuple[int, ...], epochs: int):
    def train(x, y, g, classes, seed) -> Fitted:
        from ..nets.cnn import blas_threads
        from ..nets.mlp import to_onnx, train_mlp

        with blas_threads(1):
            m = train_mlp(x, y, hidden=hidden, task="classification", classes=classes,
                          epochs=epochs, seed=seed)

        def export(path, t, meta):
            cooled = replace(m, weights=[*m.weights[:-1], m.weights[-1] / t],
                             biases=[*m.biases[:-1], m.biases[-1] / t])
            return to_onnx(cooled, path, metadata=meta)

        return Fitted(m.forward, m.n_params, export, m)
    return train


def _ensemble_trainer(cfg: FeatureConfig, hidden: tuple[int, ...], epochs: int):
    """The members of :mod:`.ensemble` on one spectrogram of ``cfg.n_bands`` log bands and
    ``cfg.linear_bins`` linear bins, pooled as (mean, deviation, change) x all columns:
    logistic regression on the linear bins' mean and deviation (the baseline's view), one
    on the log bands' (the linear candidate's) and :data:`ENSEMBLE_MLPS` MLPs on the log
    bands' three statistics (the mlp candidate's). Each regression keeps the L2 penalty it
    chose at its first fit, as :func:`_linear_trainer` does."""
    from .ensemble import Ensemble, Member, to_onnx

    nb, total = cfg.n_bands, cfg.total_bands
    log_cols = np.r_[0:nb, total:total + nb]
    # (trainer, columns, seed offset): the first MLP is the mlp candidate's own model
    views = [(_linear_trainer(), np.r_[nb:total, total + nb:2 * total], 0),
             (_linear_trainer(), log_cols, 0)]
    views += [(_mlp_trainer(hidden, epochs), np.r_[log_cols, 2 * total:2 * total + nb],
               1000 * j) for j in range(ENSEMBLE_MLPS)]

    def train(x, y, g, classes, seed) -> Fitted:
        members = [Member(tr(x[:, cols], y, g, classes, seed + off).model, cols)
                   for tr, cols, off in views]
        m = Ensemble(members, 3 * total, list(classes))
        return Fitted(m.forward, m.n_params,
                      lambda path, t, meta: to_onnx(m, path, temperature=t, metadata=meta),
                      m)
    return train


def baseline_bins(cfg: FeatureConfig) -> int:
    """Linear bins of the baseline's plain log spectrum: one per FFT bin (1 / window
    length apart) over the band range, 4 to 256."""
    return int(min(256, max(4, (cfg.f_hi - cfg.f_lo) / (1.0 / cfg.win_s))))


def _cnn_trainer(epochs: int, max_seconds: float | None):
    """The small ResNet of :mod:`.cnn` on fixed spectrogram windows, early-stopped on 15 %
    of the training *recordings* (at least one), each fit capped at ``max_seconds``."""
    def train(x, y, g, classes, seed) -> Fitted:
        from ..nets.cnn import train_cnn

        rng = np.random.default_rng(seed)
        groups = np.unique(g)
        val = np.isin(g, rng.choice(groups, max(1, round(0.15 * len(groups))),
                                    replace=False))
        if val.all() or len(np.unique(y[~val])) < len(classes):
            val[:] = False  # too few recordings to hold some out: the training loss decides
        m, _ = train_cnn(x[~val], y[~val], classes=classes, x_val=x[val], y_val=y[val],
                         epochs=epochs, patience=5, max_seconds=max_seconds, seed=seed)

        def export(path, t, meta):
            p = dict(m.params, **{"out.w": m.params["out.w"] / t,
                                  "out.b": m.params["out.b"] / t})
            return replace(m, params=p).to_onnx(path, metadata=meta)

        return Fitted(m.forward, m.n_params, export, m)
    return train


def candidates(setup: Setup, names: Sequence[str] = CANDIDATES,
               hidden: tuple[int, ...] = (64,), epochs: int = 300,
               cnn_epochs: int = CNN_EPOCHS, cnn_max_seconds: float | None = None
               ) -> list[Candidate]:
    cfg = setup.cfg
    out = []
    for name in names:
        if name == "baseline":
            df = 1.0 / cfg.win_s
            n = baseline_bins(cfg)
            c = replace(cfg, scale="linear", n_bands=n)
            out.append(Candidate(name, f"log spectrum ({n} linear bins of {df:.3g} Hz), "
                                       "mean and deviation over time, logistic regression",
                                 FeaturePipeline(c, setup.spec(("mean", "std"))),
                                 _linear_trainer()))
        elif name == "linear":
            out.append(Candidate(name, f"{cfg.n_bands} log bands, mean and deviation over "
                                       "time, logistic regression",
                                 FeaturePipeline(cfg, setup.spec(("mean", "std"))),
                                 _linear_trainer()))
        elif name == "mlp":
            out.append(Candidate(name, f"{cfg.n_bands} log bands, mean, deviation and "
                                       f"frame-to-frame change, MLP {list(hidden)}",
                                 FeaturePipeline(cfg, setup.spec(("mean", "std", "flux"))),
                                 _mlp_trainer(hidden, epochs)))
        elif name == "ensemble":
            n = baseline_bins(cfg)
            c = replace(cfg, linear_bins=n)
            out.append(Candidate(name, f"geometric mean of logistic regressions on {n} "
                                       f"linear bins and on {cfg.n_bands} log bands (mean, "
                                       f"deviation) and {ENSEMBLE_MLPS} MLPs {list(hidden)} "
                                       "on the log bands (and frame-to-frame change)",
                                 FeaturePipeline(c, setup.spec(("mean", "std", "flux"))),
                                 _ensemble_trainer(c, hidden, epochs)))
        elif name == "cnn":
            f = setup.frames(setup.first_s)
            spec = WindowSpec(f, setup.step_s, "spectrogram")
            out.append(Candidate(name, f"small ResNet on {f}-frame log-band spectrograms "
                                       f"({setup.first_s:g} s) sliding every "
                                       f"{setup.step_s:g} s, answers averaged",
                                 FeaturePipeline(cfg, spec),
                                 _cnn_trainer(cnn_epochs, cnn_max_seconds)))
        else:
            raise ValueError(f"unknown candidate {name!r} (one of {CANDIDATES})")
    return out


# --- cross-validation -----------------------------------------------------------------------

@dataclass
class Answers:
    """One recording's running probabilities (after each growing window) and their times."""

    probs: np.ndarray
    run: np.ndarray
    t_end: np.ndarray
    fold: int = -1
    dist: np.ndarray | None = None
    """Novelty distance of each window
    (:class:`~fingertip.models.vibration.reliability.Novelty`)."""


@dataclass
class CandidateWindows:
    train: list[Windows]
    test: list[Windows]
    seconds: float


def candidate_windows(cand: Candidate, ds: Dataset, augment: AugmentConfig = NO_AUGMENT,
                      seed: int = 0, copies: list[list[Recording]] | None = None,
                      clean: CandidateWindows | None = None,
                      powers: Sequence[np.ndarray] | None = None) -> CandidateWindows:
    """Every recording's training windows (with those of ``augment.copies`` augmented
    copies of it, :mod:`.augment`; ``copies``: made already by :func:`augmented_copies`)
    and the windows it is answered on. ``clean``: this candidate's windows without
    augmentation, computed already: reused, so only the copies' windows are computed.
    ``powers``: every recording's band power under this candidate's features
    (:func:`band_powers`, shared by the candidates whose features are the same); without
    them each recording's is computed once here, for its training and answered windows."""
    t0 = time.perf_counter()
    if copies is None:
        copies = augmented_copies(ds, augment, seed, cand.pipe.cfg.canonical_rate)
    if clean is not None:
        tr = [_training_windows(cand.pipe, it.rec, extra, w)
              for it, extra, w in zip(ds.items, copies, clean.train, strict=True)]
        te = clean.test
    else:
        if powers is None:
            powers = band_powers(cand.pipe, ds)
        tr = [_training_windows(cand.pipe, it.rec, extra, cand.pipe.windows(it.rec, True, pw))
              for it, extra, pw in zip(ds.items, copies, powers, strict=True)]
        te = [cand.pipe.windows(it.rec, power=pw)
              for it, pw in zip(ds.items, powers, strict=True)]
    short = [ds.rel(it) for it, w in zip(ds.items, te, strict=True) if not len(w)]
    if short:
        log.warning("%d recording(s) shorter than the first window give no answer: %s",
                    len(short), ", ".join(short[:5]))
    return CandidateWindows(tr, te, time.perf_counter() - t0)


def band_powers(pipe: FeaturePipeline, ds: Dataset) -> list[np.ndarray]:
    """Every recording's band power under ``pipe``'s features (the costly part of the
    windows: the short-time spectrum), to share between candidates and between a
    recording's training and answered windows."""
    return [pipe.power(it.rec) for it in ds.items]


def augmented_copies(ds: Dataset, augment: AugmentConfig, seed: int = 0,
                     canonical: int = CANONICAL_RATE) -> list[list[Recording]]:
    """The augmented copies of every recording of ``ds`` (reproducible from ``seed`` and
    the recording's index), at the features' working rate."""
    return [augmented(it.rec, augment, [seed, i], canonical) if augment.copies else []
            for i, it in enumerate(ds.items)]


def _training_windows(pipe: FeaturePipeline, rec: Recording, copies: list[Recording],
                      w: Windows | None = None) -> Windows:
    if w is None:
        w = pipe.windows(rec, training=True)
    if not copies or not len(w):
        return w
    ws = [w]
    for r in copies:
        a = pipe.windows(r, training=True)
        # of a copy, only what the model answers at run time (the windows from the start;
        # all of a spectrogram model's): the copies teach invariance at a third of the rows
        keep = a.growing if a.growing is not None else np.ones(len(a), bool)
        if keep.any():  # a copy too short for one window (sped up) adds nothing
            ws.append(Windows(*(getattr(a, f)[keep] for f in
                                ("inputs", "t_start", "t_end", "level_db", "clipped")),
                              None if a.growing is None else a.growing[keep]))
    return Windows(*(np.concatenate([getattr(a, f) for a in ws]) for f in
                     ("inputs", "t_start", "t_end", "level_db", "clipped")),
                   None if w.growing is None else np.concatenate([a.growing for a in ws]))


def training_rows(cw: CandidateWindows, labels: np.ndarray, idx: np.ndarray, k: int
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(inputs, labels, recording) of the training windows of recordings ``idx``."""
    rows = [i for i in idx if len(cw.train[i])]
    if not rows:
        raise DatasetError("no training windows (recordings too short?)")
    x = np.concatenate([cw.train[i].inputs for i in rows])
    y = np.concatenate([np.full(len(cw.train[i]), labels[i]) for i in rows])
    g = np.concatenate([np.full(len(cw.train[i]), i) for i in rows])
    if len(np.unique(y)) < k:
        raise DatasetError("some class has no training window (recordings too short?)")
    return x, y, g


def fit_on(cand: Candidate, cw: CandidateWindows, labels: np.ndarray, idx: np.ndarray,
           classes: list[str], seed: int) -> Fitted:
    x, y, g = training_rows(cw, labels, idx, len(classes))
    return cand.train(x, y, g, classes, seed)


def novelty_on(cw: CandidateWindows, labels: np.ndarray, idx: np.ndarray, k: int
               ) -> Novelty:
    """The novelty model of the training windows of ``idx`` (each recording weighs the
    same)."""
    x, y, g = training_rows(cw, labels, idx, k)
    _, inv, counts = np.unique(g, return_inverse=True, return_counts=True)
    return Novelty.fit(x, y, k, 1.0 / counts[inv])


def answers_of(fitted: Fitted, w: Windows, fold: int = -1,
               novelty: Novelty | None = None) -> Answers:
    p = fitted.forward(w.inputs)
    return Answers(p, running(p, w.growing), w.t_end, fold,
                   None if novelty is None else novelty.distance(w.inputs))


def cross_validate(cand: Candidate, cw: CandidateWindows, labels: np.ndarray,
                   folds: list[np.ndarray], classes: list[str], seed: int,
                   stop: Callable[[dict[int, Answers]], bool] | None = None
                   ) -> dict[int, Answers]:
    """Out-of-fold answers of every recording of ``folds`` (test sets; each fold's model
    is trained on the recordings of the other folds). ``stop``: asked after each fold
    but the last with the answers so far; True ends the cross-validation there (the
    answers returned are then those of the folds run)."""
    pool = np.concatenate(folds)
    out: dict[int, Answers] = {}
    for f, te in enumerate(folds):
        tr = np.setdiff1d(pool, te)
        t0 = time.perf_counter()
        m = fit_on(cand, cw, labels, tr, classes, seed)
        cand.last, cand.last_fit_s = m, time.perf_counter() - t0
        nov = novelty_on(cw, labels, tr, len(classes))
        for i in te:
            if len(cw.test[i]):
                out[int(i)] = answers_of(m, cw.test[i], f, nov)
        if stop is not None and f < len(folds) - 1 and stop(out):
            log.info("cross-validation of %s stopped after %d of %d folds", cand.name,
                     f + 1, len(folds))
            break
    return out


def best_case(part: dict[int, Answers], every: dict[int, Answers], labels: np.ndarray
              ) -> dict[int, Answers]:
    """``part``, completed with a right and certain answer for each recording of
    ``every`` it lacks (at the same times): scored, the most a cross-validation that
    ``part`` began can still reach."""
    out = dict(part)
    for i, a in every.items():
        if i not in out:
            sure = np.zeros_like(a.run)
            sure[:, labels[i]] = 1.0
            out[i] = Answers(sure, sure, a.t_end, a.fold)
    return out


@dataclass
class Trial:
    """A variant of a candidate cross-validated against the mean accuracy it must reach."""

    answers: dict[int, Answers]
    """Out-of-fold answers of the folds run."""
    folds_run: int
    table: dict[str, dict] | None
    """Accuracy by decision time when every fold ran; None when it stopped early."""
    bound: float | None
    """When stopped early: the most its mean accuracy could still have reached."""

    @property
    def accuracy(self) -> float | None:
        return None if self.table is None else mean_accuracy(self.table)


def cross_validate_against(cand: Candidate, cw: CandidateWindows, labels: np.ndarray,
                           folds: list[np.ndarray], classes: list[str], seed: int,
                           clean: dict[int, Answers], need: float) -> Trial:
    """Cross-validate ``cand`` (windows ``cw``) on ``folds`` to be compared with ``need``,
    a mean accuracy over the decision times. The folds stop early once even right answers
    on every recording of ``clean`` (the plain model's answers) still to come could not
    reach ``need``: the remaining folds could not change the decision."""
    stopped: list[int] = []

    def lost(part: dict[int, Answers]) -> bool:
        if mean_accuracy(accuracy_by_time(best_case(part, clean, labels), labels)) < need:
            stopped.append(len({a.fold for a in part.values()}))
        return bool(stopped)

    ans = cross_validate(cand, cw, labels, folds, classes, seed, stop=lost)
    if stopped:
        bound = mean_accuracy(accuracy_by_time(best_case(ans, clean, labels), labels))
        return Trial(ans, stopped[0], None, bound)
    return Trial(ans, len(folds), accuracy_by_time(ans, labels), None)


def cnn_work(cw: CandidateWindows, n_fits: int, epochs: int = CNN_EPOCHS) -> int:
    """Projected work of the CNN candidate's training in window-epochs: its training
    windows of every recording x ``epochs`` x ``n_fits`` (the folds and the final model).
    An upper bound (a fold trains on fewer recordings; early stopping usually ends sooner)
    that depends on the data only, never on the machine."""
    return sum(len(w) for w in cw.train) * epochs * n_fits


# --- scores ---------------------------------------------------------------------------------

def fold_temperatures(ans: dict[int, Answers], labels: np.ndarray, n_folds: int,
                      times: Sequence[float | None] = DECISION_TIMES) -> list[float]:
    """For each fold, the temperature fitted on the other folds' out-of-fold answers (at
    the decision times): every fold is then calibrated without seeing its own recordings."""
    out = []
    for f in range(n_folds):
        p, y = _at_times({i: a for i, a in ans.items() if a.fold != f}, labels, times)
        out.append(fit_temperature(p, y))
    return out


def _at_times(ans: dict[int, Answers], labels: np.ndarray,
              times: Sequence[float | None]) -> tuple[np.ndarray, np.ndarray]:
    ps, ys = [], []
    for i, a in ans.items():
        for t in times:
            q = at_time(a.run, a.t_end, t)
            if q is not None:
                ps.append(q)
                ys.append(labels[i])
    k = next(iter(ans.values())).run.shape[1] if ans else 0
    return np.array(ps).reshape(-1, k), np.array(ys, np.int64)


def calibrated(ans: dict[int, Answers], temps: Sequence[float]) -> dict[int, Answers]:
    """The answers with each fold's temperature applied (running probabilities too)."""
    out = {}
    for i, a in ans.items():
        t = temps[a.fold] if 0 <= a.fold < len(temps) else 1.0
        out[i] = Answers(apply_temperature(a.probs, t), apply_temperature(a.run, t),
                         a.t_end, a.fold, a.dist)
    return out


def accuracy_by_time(ans: dict[int, Answers], labels: np.ndarray,
                     times: Sequence[float | None] = DECISION_TIMES) -> dict[str, dict]:
    """Per decision time: accuracy over the recordings that lasted that long (per
    recording, the running answer at that time) and how many they were."""
    out = {}
    for t in times:
        hits = []
        for i, a in ans.items():
            if t is not None and a.t_end[-1] < t - LASTED_TOL_S:
                continue  # the recording ended before t: it has no answer *at* t
            q = at_time(a.run, a.t_end, t)
            hits.append(q is not None and int(np.argmax(q)) == labels[i])
        out[time_label(t)] = {"seconds": t, "accuracy": float(np.mean(hits)) if hits
                              else math.nan, "recordings": len(hits)}
    return out


def decision_curve(ans: dict[int, Answers], labels: np.ndarray,
                   thresholds: Sequence[float] = THRESHOLDS) -> list[dict]:
    """Per threshold: accuracy of the decisions (first running answer at or above it,
    else the last answer) and the median and 90th percentile time to decision."""
    from .anytime import decide

    out = []
    for th in thresholds:
        ok, ts, undecided = [], [], 0
        for i, a in ans.items():
            k = a.run.shape[1]
            d = decide(a.run, a.t_end, [str(j) for j in range(k)], th)
            ok.append(d.label is not None and int(d.label) == labels[i])
            ts.append(d.t)
            undecided += not d.decided
        out.append({"threshold": th, "accuracy": float(np.mean(ok)),
                    "median_s": float(np.median(ts)), "p90_s": float(np.percentile(ts, 90)),
                    "undecided": undecided})
    return out


def time_to_decision(curve: list[dict], target: float = TARGET_ACCURACY) -> dict:
    """The lowest threshold whose decisions are ``target`` accurate, and its median time
    (None when no threshold reaches it)."""
    for row in curve:
        if row["accuracy"] >= target:
            return {"target_accuracy": target, **row}
    return {"target_accuracy": target, "threshold": None, "accuracy": None,
            "median_s": None, "p90_s": None, "undecided": None}


def ece_of(ans: dict[int, Answers], labels: np.ndarray,
           times: Sequence[float | None] = DECISION_TIMES) -> tuple[float, np.ndarray,
                                                                     np.ndarray]:
    """(ECE, confidence, correct) of the running answers at the decision times."""
    p, y = _at_times(ans, labels, times)
    if not len(p):
        return 0.0, np.zeros(0), np.zeros(0, bool)
    conf = p.max(axis=1)
    ok = p.argmax(axis=1) == y
    return ece(conf, ok), conf, ok


def mean_accuracy(table: dict[str, dict]) -> float:
    v = [r["accuracy"] for r in table.values() if r["recordings"] and
         math.isfinite(r["accuracy"])]
    return float(np.mean(v)) if v else math.nan


def unknown_auroc(cand: Candidate, cw: CandidateWindows, ds: Dataset, left_out: str,
                  k: int = 5, seed: int = 0) -> dict:
    """Leave class ``left_out`` out of training: a ``k``-fold cross-validation on the other
    classes, whose fold models also answer every recording of ``left_out``. Returns the ROC
    AUC of the novelty distance (:class:`~fingertip.models.vibration.reliability.Novelty`, the last
    window) of the left-out recordings (answered by every fold model: k answers each)
    against the known ones (out of fold), the same for the softmax's own score (1 - top
    calibrated probability), and the share of each answered "unknown" at the trainer's
    rule (above the distance 95 % of known recordings stay below)."""
    from .reliability import auroc, unknown_score

    c_out = ds.classes.index(left_out)
    labels_all = ds.labels
    known = np.flatnonzero(labels_all != c_out)
    gone = np.flatnonzero(labels_all == c_out)
    classes = [c for c in ds.classes if c != left_out]
    labels = np.where(labels_all > c_out, labels_all - 1, labels_all)
    folds = [known[f] for f in stratified_folds(labels[known], k, seed)]
    ans: dict[int, Answers] = {}
    foreign: list[Answers] = []
    for f, te in enumerate(folds):
        tr = np.setdiff1d(known, te)
        m = fit_on(cand, cw, labels, tr, classes, seed)
        nov = novelty_on(cw, labels, tr, len(classes))
        for i in te:
            if len(cw.test[i]):
                ans[int(i)] = answers_of(m, cw.test[i], f, nov)
        foreign += [answers_of(m, cw.test[i], f, nov) for i in gone if len(cw.test[i])]
    temps = fold_temperatures(ans, labels, len(folds))
    known_d = np.array([a.dist[-1] for a in ans.values()])
    out_d = np.array([a.dist[-1] for a in foreign])
    known_p = unknown_score(np.array([a.run[-1] for a in calibrated(ans, temps).values()]))
    out_p = unknown_score(np.array([apply_temperature(a.run[-1], temps[a.fold])
                                    for a in foreign]))
    level = float(np.quantile(known_d, UNKNOWN_KEEP))
    return {"left_out": left_out, "auroc": auroc(out_d, known_d),
            "auroc_softmax": auroc(out_p, known_p),
            "known_recordings": len(known_d), "left_out_answers": len(out_d),
            "left_out_answered_unknown": float(np.mean(out_d > level)),
            "known_answered_unknown": float(np.mean(known_d > level))}


def novelty_threshold(ans: dict[int, Answers]) -> float:
    """The novelty distance that :data:`UNKNOWN_KEEP` of the known recordings' final
    answers (out of fold) stay below."""
    d = [a.dist[-1] for a in ans.values() if a.dist is not None and len(a.dist)]
    return float(np.quantile(d, UNKNOWN_KEEP)) if d else math.inf

