"""What the vibration classifiers share: labelled folders, splits by recording, evaluation,
confusion matrices, and running a trained model on a file or a live stream.

A dataset is a folder with one sub-folder per class of recordings (WAV, FLAC or CSV; see
:func:`fingertip.models.features.read_recording`). Evaluation is always split **by
recording**: every window of a recording is on the same side, train or test, and each class
contributes test recordings in proportion (stratified).

A trained model is one ONNX file whose metadata carries everything needed to run it: the
feature configuration (band edges, frame hop), the window (frames, step), the kind of input
(``pooled`` summary features for an MLP, or ``spectrogram`` windows for the CNN) and the
class names. :class:`VibrationClassifier` loads it (numpy, scipy and onnxruntime only) and
classifies a recording (:meth:`~VibrationClassifier.classify`) or a live
:class:`~fingertip.audio.AudioSource` (:meth:`~VibrationClassifier.stream`), with
timestamps, the window's level and a clipping flag on every prediction.
"""
from __future__ import annotations

import json
import logging
import math
import os
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..badfile import BadFileError
from .features import (
    AUDIO_EXTENSIONS,
    CLIP_FLAG,
    CSV_EXTENSIONS,
    FeatureConfig,
    FeatureError,
    Recording,
    Spectrogrammer,
    as_recording,
    clipped_mask,
    gather_windows,
    STATS,
    log_window,
    pooled,
    read_recording,
    window_starts,
)

log = logging.getLogger(__name__)

INPUTS = ("pooled", "spectrogram", "growing")
MODEL_FORMAT = "fingertip-vibration-1"


class DatasetError(ValueError):
    """A training folder that cannot be used (layout, too few recordings, unreadable)."""


# --- datasets -------------------------------------------------------------------------------

@dataclass
class Labelled:
    path: Path
    cls: str
    label: int
    rec: Recording


@dataclass
class Dataset:
    folder: Path
    classes: list[str]
    items: list[Labelled]
    skipped: list[str] = field(default_factory=list)

    @property
    def labels(self) -> np.ndarray:
        return np.array([it.label for it in self.items], dtype=np.int64)

    @property
    def rates(self) -> list[float]:
        return sorted({it.rec.rate for it in self.items})

    def counts(self) -> dict[str, int]:
        return {c: sum(1 for it in self.items if it.cls == c) for c in self.classes}

    def rel(self, it: Labelled) -> str:
        try:
            return str(it.path.relative_to(self.folder))
        except ValueError:
            return str(it.path)


def scan_folder(folder: str | os.PathLike) -> tuple[list[str], list[tuple[Path, str]]]:
    """(classes, [(file, class)]) of a folder with one sub-folder per class (files found
    recursively inside each; hidden files and other extensions ignored)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise DatasetError(f"{folder}: not a folder (expected one sub-folder per class)")
    exts = AUDIO_EXTENSIONS + CSV_EXTENSIONS
    classes, files = [], []
    for sub in sorted(p for p in folder.iterdir() if p.is_dir() and not p.name.startswith(".")):
        found = sorted(p for p in sub.rglob("*") if p.is_file() and p.suffix.lower() in exts
                       and not any(part.startswith(".") for part in p.relative_to(sub).parts))
        if found:
            classes.append(sub.name)
            files += [(p, sub.name) for p in found]
    if len(classes) < 2:
        raise DatasetError(f"{folder}: found {len(classes)} class folder(s) with recordings "
                           f"({', '.join(classes) or 'none'}); need at least 2 sub-folders, "
                           f"one per class, holding {'/'.join(exts)} files")
    return classes, files


def load_folder(folder: str | os.PathLike, *, rate_hint: float | None = None,
                channel: int = 0, skip_bad: bool = True,
                progress: Callable[[int, int], None] | None = None) -> Dataset:
    """Read every recording of a class-per-sub-folder dataset.

    ``rate_hint``: the sample rate of CSV files that do not state theirs. Unreadable files
    (or NaN/Inf samples) are skipped with a warning when ``skip_bad``, else raise.
    """
    folder = Path(folder)
    classes, files = scan_folder(folder)
    items, skipped = [], []
    for i, (path, cls) in enumerate(files):
        try:
            rec = read_recording(path, rate_hint, channel)
        except FeatureError as e:
            if not skip_bad:
                raise
            log.warning("skipped: %s", e)
            skipped.append(f"{path}: {e}")
            continue
        if rec.clipped:
            log.warning("%s: %.2f %% of the samples look clipped", path,
                        100 * rec.clipped_fraction)
        items.append(Labelled(path, cls, classes.index(cls), rec))
        if progress is not None:
            progress(i + 1, len(files))
    present = [c for c in classes if any(it.cls == c for it in items)]
    if len(present) < 2:
        raise DatasetError(f"{folder}: fewer than two classes have readable recordings")
    if present != classes:
        items = [Labelled(it.path, it.cls, present.index(it.cls), it.rec) for it in items]
    return Dataset(folder, present, items, skipped)


def split_by_recording(labels: Sequence[int], test_fraction: float = 0.25, seed: int = 0
                       ) -> tuple[np.ndarray, np.ndarray]:
    """(train, test) indices of recordings, stratified by class: each class with two or
    more recordings puts ``round(n * test_fraction)`` of them (at least one, at most n - 1)
    on the test side. A class with a single recording stays in training (warned)."""
    if not 0 < test_fraction < 1:
        raise ValueError("test_fraction must be between 0 and 1")
    labels = np.asarray(labels)
    rng = np.random.default_rng(seed)
    test = []
    for c in np.unique(labels):
        idx = np.flatnonzero(labels == c)
        if len(idx) < 2:
            log.warning("class %s has one recording: it cannot be tested (train only)", c)
            continue
        k = min(len(idx) - 1, max(1, int(round(len(idx) * test_fraction))))
        test += rng.permutation(idx)[:k].tolist()
    test_idx = np.array(sorted(test), dtype=np.intp)
    train_idx = np.setdiff1d(np.arange(len(labels)), test_idx)
    return train_idx, test_idx


def stratified_folds(labels: Sequence[int], k: int, seed: int = 0) -> list[np.ndarray]:
    """``k`` disjoint test sets of recordings covering every recording once, each class
    spread evenly over the folds (cross-validation by recording)."""
    if k < 2:
        raise ValueError("cross-validation needs 2 or more folds")
    labels = np.asarray(labels)
    rng = np.random.default_rng(seed)
    fold_of = np.empty(len(labels), dtype=np.intp)
    offset = 0
    for c in np.unique(labels):
        idx = rng.permutation(np.flatnonzero(labels == c))
        if len(idx) < k:
            raise DatasetError(f"{k}-fold cross-validation needs {k} or more recordings per "
                               f"class; class {c} has {len(idx)}")
        fold_of[idx] = (np.arange(len(idx)) + offset) % k
        offset += len(idx)  # classes with few recordings do not all start at fold 0
    return [np.flatnonzero(fold_of == f) for f in range(k)]


def validation_split(labels: Sequence[int], pool: np.ndarray, seed: int = 0,
                     fraction: float = 0.15) -> tuple[np.ndarray, np.ndarray]:
    """Hold ``fraction`` of each class's training recordings ``pool`` out (at least one,
    for classes with three or more there) for early stopping. Returns (fit, validation)."""
    labels = np.asarray(labels)
    rng = np.random.default_rng(seed + 1)
    val: list[int] = []
    for c in np.unique(labels[pool]):
        idx = pool[labels[pool] == c]
        if len(idx) >= 3:
            k = min(len(idx) - 2, max(1, int(round(fraction * len(idx)))))
            val += rng.permutation(idx)[:k].tolist()
    val_idx = np.array(sorted(val), dtype=np.intp)
    return np.setdiff1d(pool, val_idx), val_idx


# --- evaluation -----------------------------------------------------------------------------

@dataclass
class Evaluation:
    """Confusion matrix (rows: true class, columns: predicted) and what follows from it."""

    classes: list[str]
    confusion: np.ndarray
    unit: str = "windows"

    @property
    def n(self) -> int:
        return int(self.confusion.sum())

    @property
    def accuracy(self) -> float:
        return float(np.trace(self.confusion) / self.n) if self.n else math.nan

    @property
    def recall(self) -> dict[str, float]:
        rows = self.confusion.sum(axis=1)
        return {c: float(self.confusion[i, i] / rows[i]) if rows[i] else math.nan
                for i, c in enumerate(self.classes)}

    @property
    def precision(self) -> dict[str, float]:
        cols = self.confusion.sum(axis=0)
        return {c: float(self.confusion[i, i] / cols[i]) if cols[i] else math.nan
                for i, c in enumerate(self.classes)}

    def most_confused(self) -> tuple[str, str, int]:
        """The pair of classes mistaken for each other most often (both directions)."""
        m = self.confusion + self.confusion.T
        np.fill_diagonal(m, -1)
        i, j = np.unravel_index(int(np.argmax(m)), m.shape)
        a, b = sorted((int(i), int(j)))
        return self.classes[a], self.classes[b], int(max(m[a, b], 0))

    def to_dict(self) -> dict:
        a, b, k = self.most_confused()
        return {"unit": self.unit, "n": self.n, "accuracy": self.accuracy,
                "recall": self.recall, "precision": self.precision,
                "confusion": self.confusion.tolist(), "classes": self.classes,
                "most_confused": {"classes": [a, b], "count": k}}


def evaluate(y_true: Sequence[int], y_pred: Sequence[int], classes: list[str],
             unit: str = "windows") -> Evaluation:
    k = len(classes)
    cm = np.zeros((k, k), dtype=np.int64)
    np.add.at(cm, (np.asarray(y_true, np.intp), np.asarray(y_pred, np.intp)), 1)
    return Evaluation(list(classes), cm, unit)


def majority_vote(probabilities: np.ndarray) -> int:
    """The class predicted most often over windows (ties: the higher summed probability)."""
    p = np.asarray(probabilities)
    if p.ndim != 2 or not len(p):
        raise ValueError("need a (windows, classes) array with at least one window")
    votes = np.bincount(p.argmax(axis=1), minlength=p.shape[1]).astype(float)
    votes += 1e-6 * p.sum(axis=0) / len(p)  # tie-break, never outweighs one vote
    return int(np.argmax(votes))


def plot_confusion(ev: Evaluation, path: str | os.PathLike, title: str = "") -> Path:
    """A PNG of the confusion matrix: rows normalised to the true class (colour and
    percentage), with the counts."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    cm = ev.confusion
    rows = cm.sum(axis=1, keepdims=True)
    frac = np.divide(cm, rows, out=np.zeros(cm.shape), where=rows > 0)
    k = len(ev.classes)
    size = 2.2 + 0.75 * k
    fig, ax = plt.subplots(figsize=(size + 1.2, size), dpi=110)
    im = ax.imshow(frac, cmap="Blues", vmin=0, vmax=1)
    ax.set_xticks(range(k), ev.classes, rotation=40, ha="right")
    ax.set_yticks(range(k), ev.classes)
    ax.set_xlabel("predicted")
    ax.set_ylabel("true")
    for i in range(k):
        for j in range(k):
            if cm[i, j]:
                ax.text(j, i, f"{100 * frac[i, j]:.0f}%\n({cm[i, j]})", ha="center",
                        va="center", fontsize=7, color="white" if frac[i, j] > 0.5
                        else "black")
    ax.set_title(title or f"accuracy {100 * ev.accuracy:.2f} % over {ev.n} {ev.unit}",
                 fontsize=9)
    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04, label="share of the true class")
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path


# --- windows --------------------------------------------------------------------------------

@dataclass(frozen=True)
class WindowSpec:
    """How a recording is cut into classifier inputs."""

    frames: int
    """STFT frames per window (86 = 1.0 s)."""
    step_s: float
    """One prediction every ``step_s`` seconds."""
    input: str = "pooled"
    min_frames: int | None = None
    """Pooled input: a recording shorter than a window but with at least this many frames
    gives one (shorter) window instead of none. Growing input: the first window's frames
    (``frames`` is then the longest window, after which windows slide)."""
    stats: tuple[str, ...] = STATS
    """Pooled and growing inputs: the summary statistics per band, in order."""

    def __post_init__(self) -> None:
        if self.input not in INPUTS:
            raise ValueError(f"input must be one of {INPUTS}, not {self.input!r}")
        if self.frames < 2 or not self.step_s > 0:
            raise ValueError("a window needs 2 or more frames and a positive step")


@dataclass
class Windows:
    """The classifier inputs of one recording, with where they lie in it."""

    inputs: np.ndarray
    """(n, 3 x bands) pooled features, or (n, frames, bands) spectrograms (dB)."""
    t_start: np.ndarray
    t_end: np.ndarray
    level_db: np.ndarray
    clipped: np.ndarray
    """Share of clipped samples in each window."""
    growing: np.ndarray | None = None
    """Growing input only: whether each window still starts at the recording's start."""

    def __len__(self) -> int:
        return len(self.inputs)


class FeaturePipeline:
    """Recording -> classifier windows, the same for training and running."""

    def __init__(self, cfg: FeatureConfig, spec: WindowSpec, dtype: type = np.float32
                 ) -> None:
        self.cfg = cfg
        self.spec = spec
        self.spectro = Spectrogrammer(cfg, dtype)

    @property
    def input_shape(self) -> tuple[int, ...]:
        """One window's input: (statistics x bands,) pooled or growing, or (frames, bands)
        spectrogram."""
        n = self.cfg.n_bands
        if self.spec.input == "spectrogram":
            return (self.spec.frames, n)
        return (len(self.spec.stats) * n,)

    def span_s(self) -> float:
        """Seconds of audio one window needs."""
        return (self.spec.frames - 1) * self.cfg.hop_s + self.cfg.win_s

    def windows(self, rec: Recording, training: bool = False,
                power: np.ndarray | None = None) -> Windows:
        """The windows of ``rec``; ``training``: for a growing model, the windows it is
        trained on (:func:`~fingertip.models.anytime.training_bounds`) instead of the
        ones it answers on. ``power``: ``rec``'s band power under this pipeline's
        features, computed already (:meth:`power`; a trainer shares it between uses)."""
        cfg, sp = self.cfg, self.spec
        if power is None:
            power = self.power(rec)
        if sp.input == "growing":
            return self._growing(rec, power, training)
        starts = window_starts(len(power), sp.frames, sp.step_s, cfg.hop_s)
        frames = sp.frames
        if not len(starts) and sp.input == "pooled" and sp.min_frames \
                and len(power) >= sp.min_frames:
            starts, frames = np.zeros(1, dtype=np.intp), len(power)
        logw = log_window(gather_windows(power, starts, frames), cfg.floor_db)
        inputs = pooled(logw, sp.stats) if sp.input == "pooled" else logw
        t0 = starts * cfg.hop_s
        t1 = t0 + (frames - 1) * cfg.hop_s + cfg.win_s
        lv, cl = _window_stats(rec, t0, t1)
        return Windows(inputs, t0, t1, lv, cl)

    def power(self, rec: Recording) -> np.ndarray:
        """(frames, bands) band power of ``rec`` under this pipeline's features."""
        return self.spectro(rec.samples, rec.rate, rec.source or "the recording")

    def _growing(self, rec: Recording, power: np.ndarray, training: bool) -> Windows:
        from .anytime import growing_bounds, span_features, training_bounds

        cfg, sp = self.cfg, self.spec
        bounds = training_bounds if training else growing_bounds
        starts, ends = bounds(len(power), sp.frames, sp.min_frames or 1, sp.step_s / cfg.hop_s)
        inputs = span_features(power, starts, ends, cfg.floor_db, sp.stats)
        t0 = starts * cfg.hop_s
        t1 = (ends - 1) * cfg.hop_s + cfg.win_s
        lv, cl = _window_stats(rec, t0, t1)
        return Windows(inputs, t0, t1, lv, cl, starts == 0)

    def min_span_s(self) -> float:
        """Seconds of audio the first prediction needs."""
        frames = self.spec.min_frames if self.spec.input != "spectrogram" \
            and self.spec.min_frames else self.spec.frames
        return (frames - 1) * self.cfg.hop_s + self.cfg.win_s


def _window_stats(rec: Recording, t0: np.ndarray, t1: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Level (dB of the recording's units, mean removed) and clipped share per window."""
    x = np.asarray(rec.samples, dtype=np.float64)
    if not len(t0):
        return np.zeros(0), np.zeros(0)
    x = x - x.mean()  # cumulative sums of an offset signal would cancel catastrophically
    i0 = np.clip(np.rint(t0 * rec.rate).astype(np.intp), 0, len(x))
    i1 = np.clip(np.rint(t1 * rec.rate).astype(np.intp), 0, len(x))
    c1 = np.concatenate([[0.0], np.cumsum(x)])
    c2 = np.concatenate([[0.0], np.cumsum(x * x)])
    n = np.maximum(i1 - i0, 1)
    mean = (c1[i1] - c1[i0]) / n
    var = np.maximum((c2[i1] - c2[i0]) / n - mean * mean, 0)
    with np.errstate(divide="ignore"):
        lv = np.where(var > 0, 10 * np.log10(np.where(var > 0, var, 1)), -np.inf)
    if rec.clipped_fraction > 0:
        mask = clipped_mask(rec.samples, rec.full_scale)
        cm = np.concatenate([[0], np.cumsum(mask)])
        cl = (cm[i1] - cm[i0]) / n
    else:
        cl = np.zeros(len(t0))
    return lv, cl


def json_safe(obj: object) -> object:
    """``obj`` with NaN and infinite floats replaced by None (strict JSON), numpy scalars
    and arrays as Python numbers and lists."""
    if isinstance(obj, dict):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return json_safe(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def require_test_set(test_idx: np.ndarray) -> None:
    if not len(test_idx):
        raise DatasetError("nothing to test on: every class has a single recording; the "
                           "evaluation is split by recording, so give some classes two or "
                           "more recordings")


# --- models ---------------------------------------------------------------------------------

def model_metadata(kind: str, cfg: FeatureConfig, spec: WindowSpec, classes: list[str],
                   **extra: object) -> dict[str, str]:
    meta = {"format": MODEL_FORMAT, "kind": kind, "input": spec.input,
            "features": json.dumps(cfg.to_dict()),
            "window": json.dumps({"frames": spec.frames, "step_s": spec.step_s,
                                  "min_frames": spec.min_frames,
                                  "stats": list(spec.stats)}),
            "classes": json.dumps(classes)}
    meta.update({k: v if isinstance(v, str) else json.dumps(json_safe(v))
                 for k, v in extra.items()})
    return meta


@dataclass
class Prediction:
    """One window's classification. Times in seconds from the start of the recording (or
    of the stream); ``host_time`` is the ``time.monotonic()`` of the window's end for live
    sources."""

    t_start: float
    t_end: float
    label: str
    probability: float
    probabilities: dict[str, float]
    level_db: float
    clipped: bool
    host_time: float | None = None
    running: dict[str, float] | None = None
    """The running class probabilities after this window (everything heard so far)."""
    novelty: float | None = None
    """How far this window lies from every trained class (squared Mahalanobis distance per
    dimension; :class:`~fingertip.models.reliability.Novelty`)."""

    def to_dict(self) -> dict:
        d = {"t_start": round(self.t_start, 4), "t_end": round(self.t_end, 4),
             "label": self.label, "probability": round(self.probability, 4),
             "probabilities": {k: round(v, 4) for k, v in self.probabilities.items()},
             "level_db": None if not math.isfinite(self.level_db) else round(self.level_db, 2),
             "clipped": self.clipped}
        if self.host_time is not None:
            d["host_time"] = round(self.host_time, 6)
        if self.running is not None:
            d["running"] = {k: round(v, 4) for k, v in self.running.items()}
        if self.novelty is not None:
            d["novelty"] = round(self.novelty, 4)
        return d


@dataclass
class Classification:
    """All predictions over a recording (or a stream) and their majority vote."""

    predictions: list[Prediction]
    classes: list[str]
    novelty_threshold: float = math.inf
    """An answer whose window lies farther than this from every class is "unknown"."""

    def _unknown(self, i: int) -> bool:
        d = self.predictions[i].novelty
        return d is not None and d > self.novelty_threshold

    def running(self) -> np.ndarray:
        """(predictions, classes) running probabilities (the window's own when the model
        gives none)."""
        return np.array([[(q.running or q.probabilities)[c] for c in self.classes]
                         for q in self.predictions]).reshape(-1, len(self.classes))

    @property
    def anytime(self) -> bool:
        return bool(self.predictions) and self.predictions[-1].running is not None

    @property
    def vote(self) -> str | None:
        """The answer for the whole recording: the last running answer of an anytime model
        (or "unknown"), the majority vote of the windows otherwise."""
        if not self.predictions:
            return None
        if self.anytime:
            last = self.running()[-1]
            return "unknown" if self._unknown(-1) else self.classes[int(np.argmax(last))]
        p = np.array([[q.probabilities[c] for c in self.classes] for q in self.predictions])
        return self.classes[majority_vote(p)]

    def decide(self, threshold: float):
        """The first moment a class's running probability reached ``threshold``
        (:class:`~fingertip.models.anytime.Decision`); undecided: the last answer. The label
        is "unknown" when that window lies farther from every class than the model's
        threshold."""
        from .anytime import decide

        t_end = np.array([q.t_end for q in self.predictions])
        d = decide(self.running(), t_end, self.classes, threshold)
        if d.label is not None:
            i = int(np.flatnonzero(np.isclose(t_end, d.t))[0])
            if self._unknown(i):
                d.label = "unknown"
        return d

    def shares(self) -> dict[str, float]:
        n = len(self.predictions)
        return {c: sum(q.label == c for q in self.predictions) / n if n else 0.0
                for c in self.classes}


class ModelError(BadFileError):
    """A model file that is not a vibration classifier of the kind asked for."""


class VibrationClassifier:
    """A trained material or shake model (ONNX + its metadata), run with onnxruntime."""

    def __init__(self, path: str | os.PathLike, kind: str | None = None, threads: int = 1
                 ) -> None:
        from .mlp import OnnxModel

        self.model = OnnxModel(path, threads=threads)
        meta = self.model.metadata
        if meta.get("format") != MODEL_FORMAT:
            raise ModelError(f"{path} is not a vibration classifier made by `fingertip train` "
                             f"(format {meta.get('format')!r})", path)
        self.kind = meta.get("kind", "")
        if kind is not None and self.kind != kind:
            raise ModelError(f"{path} is a {self.kind} model, not a {kind} model", path)
        self.path = Path(path)
        self.meta = meta
        try:  # a hand-edited or foreign graph: say so instead of a KeyError deep inside
            self.cfg = FeatureConfig.from_dict(json.loads(meta["features"]))
            w = json.loads(meta["window"])
            self.spec = WindowSpec(int(w["frames"]), float(w["step_s"]), meta["input"],
                                   w.get("min_frames"), tuple(w.get("stats", STATS)))
            self.classes: list[str] = [str(c) for c in json.loads(meta["classes"])]
            self.temperature = float(json.loads(meta.get("temperature", "1")))
            self.novelty = None
            if "novelty" in meta:
                from .reliability import Novelty

                self.novelty = Novelty.from_dict(json.loads(meta["novelty"]))
        except (KeyError, TypeError, ValueError, AttributeError) as e:
            raise ModelError(f"{path}: its classifier metadata is incomplete or damaged "
                             f"({type(e).__name__}: {e})", path) from e
        self.pipeline = FeaturePipeline(self.cfg, self.spec)
        self._check_graph(path)

    def _check_graph(self, path: str | os.PathLike) -> None:
        """Refuse a graph whose input or output does not fit the metadata (a graph swapped
        in from another model), before any audio is read."""
        want = self.pipeline.input_shape
        got = self.model.session.get_inputs()[0].shape
        fixed = [d if isinstance(d, int) else None for d in got[1:]]
        if len(fixed) != len(want) or any(d is not None and d != w
                                          for d, w in zip(fixed, want, strict=True)):
            shown = ", ".join("?" if d is None else str(d) for d in fixed)
            raise ModelError(f"{path}: the graph takes inputs of shape ({shown}) but its "
                             f"metadata describes ({', '.join(map(str, want))}): not the "
                             f"graph `fingertip train` wrote for it", path)
        out = self.model.session.get_outputs()[0].shape
        if not self.classes or (isinstance(out[-1], int) and out[-1] != len(self.classes)):
            raise ModelError(f"{path}: the graph outputs {out[-1]} values for "
                             f"{len(self.classes)} classes", path)

    @property
    def novelty_threshold(self) -> float:
        return math.inf if self.novelty is None else self.novelty.threshold

    @property
    def architecture(self) -> str:
        return self.meta.get("model", "mlp")

    def predict(self, inputs: np.ndarray) -> np.ndarray:
        """Probabilities (n, classes) for inputs made by the pipeline."""
        if not len(inputs):
            return np.zeros((0, len(self.classes)), dtype=np.float32)
        return self.model(np.ascontiguousarray(inputs, dtype=np.float32))

    def _predictions(self, w: Windows, probs: np.ndarray, offset: float = 0.0,
                     host: Sequence[float] | None = None,
                     run: np.ndarray | None = None) -> list[Prediction]:
        out = []
        dist = None if self.novelty is None else self.novelty.distance(w.inputs)
        for i in range(len(w)):
            p = probs[i]
            k = int(np.argmax(p))
            out.append(Prediction(float(w.t_start[i] + offset), float(w.t_end[i] + offset),
                                  self.classes[k], float(p[k]),
                                  dict(zip(self.classes, map(float, p), strict=True)),
                                  float(w.level_db[i]), bool(w.clipped[i] > CLIP_FLAG),
                                  None if host is None else float(host[i]),
                                  None if run is None else
                                  dict(zip(self.classes, map(float, run[i]), strict=True)),
                                  None if dist is None else float(dist[i])))
        return out

    def classify(self, rec: Recording | str | os.PathLike, rate: float | None = None
                 ) -> Classification:
        """Every window of a recording (a :class:`Recording`, or a file: ``rate`` for a CSV
        that does not state its own)."""
        if not isinstance(rec, Recording):
            rec = read_recording(rec, rate)
        w = self.pipeline.windows(rec)
        if not len(w):
            raise FeatureError(f"{rec.source or 'the recording'} lasts {rec.duration:.3f} s: "
                               f"shorter than one window ({self.pipeline.min_span_s():.3f} s)")
        probs = self.predict(w.inputs)
        run = None
        if self.spec.input == "growing":
            from .anytime import running

            run = running(probs, w.growing)
        return Classification(self._predictions(w, probs, run=run), self.classes,
                              self.novelty_threshold)

    def live(self, sample_rate: float, what: str = "the audio source"
             ) -> _LiveWindows | _LiveGrowing:
        """A windower for audio that arrives chunk by chunk (when the chunks also go
        elsewhere, e.g. onto the network): ``live.feed(x, first_index, chunk)`` yields the
        predictions each chunk completes (``x``: one channel as floats in [-1, 1])."""
        rate = float(sample_rate)
        self.cfg.check_supports(rate, what)
        if self.spec.input == "growing":
            return _LiveGrowing(self, rate)
        return _LiveWindows(self, rate)

    def stream(self, source, *, duration: float | None = None, channel: int = 0,
               stop: Callable[[], bool] | None = None) -> Iterator[Prediction]:
        """Predictions from a live :class:`~fingertip.audio.AudioSource` (started here if it
        is not running), one every ``step_s`` once a window of audio has arrived.

        Each prediction covers the latest window; times count from the source's frame 0 and
        ``host_time`` is the host time of the window's last frame. ``duration`` (seconds of
        audio) or ``stop()`` ends it; so does the end of a file or a simulation.
        """
        live = self.live(source.sample_rate, getattr(source, "name", "the audio source"))
        rate = float(source.sample_rate)
        if not (source.running or source.finished):
            source.start()
        limit = None if duration is None else int(round(duration * rate))
        while True:
            if stop is not None and stop():
                return
            chunk = source.read(timeout=0.5)
            if chunk is None:
                if source.finished:
                    return
                continue
            x = to_float(chunk.samples[:, channel])
            first = chunk.first_index
            if limit is not None:
                x = x[:max(0, limit - first)]
            yield from live.feed(x, first, chunk)
            if limit is not None and first + chunk.frames >= limit:
                return


def to_float(x: np.ndarray) -> np.ndarray:
    """int16, int32 or float samples -> float64 in [-1, 1]."""
    if x.dtype == np.int16:
        return x.astype(np.float64) / 32768.0
    if x.dtype == np.int32:
        return x.astype(np.float64) / 2147483648.0
    return x.astype(np.float64)


class _LiveWindows:
    """Cut a stream into the model's windows: window j covers the ``span`` seconds from
    ``j * step_s`` (raw samples kept in a buffer that is trimmed as windows pass)."""

    def __init__(self, clf: VibrationClassifier, rate: float) -> None:
        self.clf = clf
        self.rate = rate
        self.span = int(math.ceil(clf.pipeline.span_s() * rate)) + 2
        self.step = clf.spec.step_s * rate
        self.buf = np.zeros(0)
        self.buf_start = 0  # absolute index of buf[0]
        self.next_j = 0
        self.expected = 0

    def feed(self, x: np.ndarray, first: int, chunk) -> Iterator[Prediction]:
        if first != self.expected:  # frames lost upstream: restart windows after the gap
            log.warning("audio gap: frames %d..%d missing; windows restart after it",
                        self.expected, first)
            self.buf = np.zeros(0)
            self.buf_start = first
            self.next_j = int(math.ceil(first / self.step))
        self.expected = first + len(x)
        self.buf = np.concatenate([self.buf, x]) if len(self.buf) else x.copy()
        clf = self.clf
        while True:
            s = int(round(self.next_j * self.step))
            e = s + self.span
            if e > self.buf_start + len(self.buf):
                break
            seg = self.buf[s - self.buf_start:e - self.buf_start]
            rec = as_recording(seg, self.rate, "live audio", full_scale=1.0)
            w = clf.pipeline.windows(rec)
            if len(w):
                w = Windows(w.inputs[:1], w.t_start[:1], w.t_end[:1], w.level_db[:1],
                            w.clipped[:1])
                host = [chunk.time_of(s + int(round(w.t_end[0] * self.rate)) - 1)]
                yield from clf._predictions(w, clf.predict(w.inputs), s / self.rate, host)
            self.next_j += 1
        keep_from = int(round(self.next_j * self.step))
        if keep_from > self.buf_start:
            cut = min(len(self.buf), keep_from - self.buf_start)
            self.buf = self.buf[cut:]
            self.buf_start += cut


class _LiveGrowing:
    """Growing windows on a stream: every ``step_s``, the summary of everything since the
    stream's start (or since a gap), at most the model's longest window, and the running
    probabilities (:func:`~fingertip.models.anytime.running`)."""

    def __init__(self, clf: VibrationClassifier, rate: float) -> None:
        self.clf = clf
        self.rate = rate
        self.step_frames = clf.spec.step_s / clf.cfg.hop_s
        self.buf = np.zeros(0)
        self.buf_start = 0
        self.origin = 0  # where the current run of windows started (0, or after a gap)
        self.next_j = 0
        self.expected = 0
        self.acc = np.zeros(len(clf.classes))
        self.n_acc = 0

    def _bounds(self, j: int) -> tuple[int, int]:
        """Samples (absolute) of window ``j``: the same STFT frames as a file's window
        (:func:`~fingertip.models.anytime.growing_bounds`)."""
        cfg, sp = self.clf.cfg, self.clf.spec
        end = (sp.min_frames or 1) + int(round(j * self.step_frames))
        start = max(0, end - sp.frames)
        s = self.origin + int(round(start * cfg.hop_s * self.rate))
        e = self.origin + int(math.ceil(((end - 1) * cfg.hop_s + cfg.win_s) * self.rate))
        return s, e

    def feed(self, x: np.ndarray, first: int, chunk) -> Iterator[Prediction]:
        if first != self.expected:
            log.warning("audio gap: frames %d..%d missing; windows restart after it",
                        self.expected, first)
            self.buf, self.buf_start, self.origin = np.zeros(0), first, first
            self.next_j, self.acc, self.n_acc = 0, np.zeros_like(self.acc), 0
        self.expected = first + len(x)
        self.buf = np.concatenate([self.buf, x]) if len(self.buf) else x.copy()
        clf = self.clf
        while True:
            s, e = self._bounds(self.next_j)
            if e > self.buf_start + len(self.buf):
                break
            seg = self.buf[s - self.buf_start:e - self.buf_start]
            w = clf.pipeline.windows(as_recording(seg, self.rate, "live audio", 1.0))
            self.next_j += 1
            if not len(w):
                continue
            w = Windows(w.inputs[-1:], np.zeros(1), w.t_end[-1:], w.level_db[-1:],
                        w.clipped[-1:], np.array([s == self.origin]))
            p = clf.predict(w.inputs)
            if s == self.origin:
                run = p
            else:
                self.acc += p[0]
                self.n_acc += 1
                run = (self.acc / self.n_acc)[None, :]
            host = [chunk.time_of(e - 1)]
            yield from clf._predictions(w, p, s / self.rate, host, run)
        keep = self._bounds(self.next_j)[0]
        if keep > self.buf_start:
            cut = min(len(self.buf), keep - self.buf_start)
            self.buf = self.buf[cut:]
            self.buf_start += cut


# --- training helpers -----------------------------------------------------------------------

def dataset_windows(ds: Dataset, pipe: FeaturePipeline,
                    progress: Callable[[int, int], None] | None = None
                    ) -> tuple[list[Windows], list[str]]:
    """Windows of every recording (a recording too short for one window has none: listed)."""
    out, short = [], []
    for i, it in enumerate(ds.items):
        w = pipe.windows(it.rec)
        if not len(w):
            short.append(ds.rel(it))
        out.append(w)
        if progress is not None:
            progress(i + 1, len(ds.items))
    return out, short


def stack(windows: list[Windows], labels: np.ndarray, rec_idx: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(inputs, labels, recording index) of the windows of recordings ``rec_idx``."""
    xs = [windows[i].inputs for i in rec_idx if len(windows[i])]
    if not xs:
        return np.zeros((0,)), np.zeros(0, np.int64), np.zeros(0, np.intp)
    ys = [np.full(len(windows[i]), labels[i]) for i in rec_idx if len(windows[i])]
    gs = [np.full(len(windows[i]), i) for i in rec_idx if len(windows[i])]
    return np.concatenate(xs), np.concatenate(ys), np.concatenate(gs)


@dataclass
class ModelEvaluation:
    """A model's test results: per window, per recording by majority vote, and each test
    recording's own window accuracy (for paired comparisons between models)."""

    windows: Evaluation
    recordings: Evaluation
    per_recording: dict[int, float] = field(default_factory=dict)
    """Recording index -> share of its windows classified correctly."""

    def to_dict(self) -> dict:
        return {"windows": self.windows.to_dict(), "recordings": self.recordings.to_dict()}


def evaluate_model(predict: Callable[[np.ndarray], np.ndarray], windows: list[Windows],
                   labels: np.ndarray, test_idx: np.ndarray, classes: list[str]
                   ) -> ModelEvaluation:
    wt, wp, rt, rp = [], [], [], []
    per: dict[int, float] = {}
    for i in test_idx:
        w = windows[i]
        if not len(w):
            continue
        p = predict(w.inputs)
        hit = p.argmax(axis=1)
        wt += [int(labels[i])] * len(w)
        wp += hit.tolist()
        rt.append(int(labels[i]))
        rp.append(majority_vote(p))
        per[int(i)] = float(np.mean(hit == labels[i]))
    return ModelEvaluation(evaluate(wt, wp, classes, "windows"),
                           evaluate(rt, rp, classes, "recordings"), per)


def merge_evaluations(parts: Sequence[ModelEvaluation]) -> ModelEvaluation:
    """The evaluations of disjoint test sets (cross-validation folds) as one."""
    first = parts[0]
    per: dict[int, float] = {}
    for p in parts:
        per.update(p.per_recording)
    return ModelEvaluation(
        Evaluation(first.windows.classes, sum(p.windows.confusion for p in parts), "windows"),
        Evaluation(first.recordings.classes, sum(p.recordings.confusion for p in parts),
                   "recordings"), per)


def paired_difference(a: ModelEvaluation, b: ModelEvaluation) -> tuple[float, float, int]:
    """Mean and standard error over test recordings of (window accuracy of ``a`` minus that
    of ``b``), and the number of recordings: windows of one recording are not independent,
    recordings are."""
    keys = sorted(set(a.per_recording) & set(b.per_recording))
    if not keys:
        return math.nan, math.nan, 0
    d = np.array([a.per_recording[k] - b.per_recording[k] for k in keys])
    se = float(d.std(ddof=1) / math.sqrt(len(d))) if len(d) > 1 else math.inf
    return float(d.mean()), se, len(d)


def latency_ms(fn: Callable[[], object], repeats: int = 200, warmup: int = 10
               ) -> dict[str, float]:
    """Median and 90th percentile wall time of ``fn()`` in milliseconds."""
    for _ in range(warmup):
        fn()
    t = np.empty(repeats)
    for i in range(repeats):
        t0 = time.perf_counter()
        fn()
        t[i] = time.perf_counter() - t0
    return {"p50": float(np.median(t) * 1e3), "p90": float(np.percentile(t, 90) * 1e3)}


def split_report(ds: Dataset, train_idx: np.ndarray, test_idx: np.ndarray,
                 val_idx: np.ndarray | None = None) -> dict:
    per = {}
    fit = np.setdiff1d(train_idx, val_idx) if val_idx is not None else train_idx
    for c in ds.classes:
        per[c] = {"train": int(sum(ds.items[i].cls == c for i in fit)),
                  "test": int(sum(ds.items[i].cls == c for i in test_idx))}
        if val_idx is not None:
            per[c]["validation"] = int(sum(ds.items[i].cls == c for i in val_idx))
    out = {"by": "recording", "per_class": per,
           "test_recordings": [ds.rel(ds.items[i]) for i in test_idx]}
    if val_idx is not None:
        out["validation_recordings"] = [ds.rel(ds.items[i]) for i in val_idx]
    return out


def dataset_summary(ds: Dataset) -> dict:
    return {"folder": str(ds.folder), "classes": ds.classes, "recordings": ds.counts(),
            "rates_hz": ds.rates, "skipped": ds.skipped,
            "clipped_recordings": [ds.rel(it) for it in ds.items if it.rec.clipped],
            "seconds": round(sum(it.rec.duration for it in ds.items), 3)}


# --- sound card of a fingertip ----------------------------------------------------------------

def sound_card_for_port(port: str) -> int:
    """The PortAudio input device of the USB sound card that shares a USB hub with the
    fingertip on serial ``port`` (its piezo preamp's card). Raises LookupError."""
    from ..audio import list_input_devices, usb_hub_of
    from ..transport import list_ports

    ports = {p.device: p for p in list_ports(include_non_usb=True)}
    info = ports.get(port) or next((p for p in ports.values()
                                    if os.path.realpath(p.device) == os.path.realpath(port)),
                                   None)
    if info is None or not info.location:
        raise LookupError(f"{port}: not a USB serial port here (ports: "
                          f"{', '.join(ports) or 'none'}); give the sound card with --audio")
    hub = usb_hub_of(info.location)
    cards = [d for d in list_input_devices()
             if d.usb_path and hub and usb_hub_of(d.usb_path) == hub]
    if len(cards) != 1:
        raise LookupError(f"{len(cards)} USB sound cards share the hub {hub or '-'} of "
                          f"{port}: give the sound card with --audio")
    return cards[0].index
