"""Running a trained vibration classifier on a file or a live stream; the classifiers' other
parts (datasets, windows, training, evaluation, voting) live in :mod:`.classifier`, and their
names are kept here for callers.

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
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...audio.pcm import to_float
from ...audio.sanity import signal_problem
from ...badfile import BadFileError
from .classifier.datasets import (
    Dataset,
    DatasetError,
    Labelled,
    dataset_summary,
    load_folder,
    scan_folder,
    split_by_recording,
    stratified_folds,
    validation_split,
)
from .classifier.evaluation import (
    Evaluation,
    ModelEvaluation,
    evaluate,
    evaluate_model,
    merge_evaluations,
    paired_difference,
    plot_confusion,
)
from .classifier.training import (
    dataset_windows,
    json_safe,
    latency_ms,
    require_test_set,
    split_report,
    stack,
)
from .classifier.voting import majority_vote
from .classifier.windows import INPUTS, FeaturePipeline, Windows, WindowSpec
from .features import (
    CLIP_FLAG,
    STATS,
    FeatureConfig,
    FeatureError,
    Recording,
    as_recording,
    read_recording,
)

__all__ = [
    "Classification", "Dataset", "DatasetError", "Evaluation", "FeaturePipeline", "INPUTS",
    "Labelled", "MODEL_FORMAT", "ModelError", "ModelEvaluation", "Prediction",
    "VibrationClassifier", "WindowSpec", "Windows", "dataset_summary", "dataset_windows",
    "evaluate", "evaluate_model", "json_safe", "latency_ms", "load_folder", "majority_vote",
    "merge_evaluations", "model_metadata", "paired_difference", "plot_confusion",
    "require_test_set", "scan_folder", "split_by_recording",
    "split_report", "stack", "stratified_folds", "validation_split"
]

log = logging.getLogger(__name__)
MODEL_FORMAT = "fingertip-vibration-1"


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
    dimension; :class:`~fingertip.models.vibration.reliability.Novelty`)."""

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
        (:class:`~fingertip.models.vibration.anytime.Decision`); undecided: the last answer.
        The label is "unknown" when that window lies farther from every class than the model's
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
        from ..nets.mlp import OnnxModel

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
        if (problem := signal_problem(rec.samples, rec.full_scale)) is not None:
            log.warning("%s: %s: its answers may mean little", rec.source or "the "
                        "recording", problem)
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
    probabilities (:func:`~fingertip.models.vibration.anytime.running`)."""

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
        (:func:`~fingertip.models.vibration.anytime.growing_bounds`)."""
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
