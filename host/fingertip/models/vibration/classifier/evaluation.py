"""How well a classifier does on held-out recordings: accuracy, per-class figures, confusion
matrices (tables and figures), and the paired comparison of two models."""
from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...nets.figures import pyplot, save_png
from .voting import majority_vote
from .windows import Windows


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


CONFUSION_MAX_INCHES = 16.0
"""The confusion figure's height at most (1760 pixels at 110 dpi)."""
CONFUSION_TEXT_MAX = 24
"""Classes up to which each cell is labelled with its share and count."""


def plot_confusion(ev: Evaluation, path: str | os.PathLike, title: str = "") -> Path:
    """A PNG of the confusion matrix: rows normalised to the true class (colour and
    percentage), with the counts."""
    plt = pyplot()

    cm = ev.confusion
    rows = cm.sum(axis=1, keepdims=True)
    frac = np.divide(cm, rows, out=np.zeros(cm.shape), where=rows > 0)
    k = len(ev.classes)
    # the figure grows with the classes up to a cap: 100 classes at 0.75 in each drew an
    # 8500-pixel square and took 3 GB and 40 s; beyond CONFUSION_TEXT_MAX classes the cells
    # are too small for their numbers (report.json has them) and only colours are drawn
    size = min(2.2 + 0.75 * k, CONFUSION_MAX_INCHES)
    fig, ax = plt.subplots(figsize=(size + 1.2, size), dpi=110)
    im = ax.imshow(frac, cmap="Blues", vmin=0, vmax=1)
    tick = max(3.0, min(9.0, 400.0 / k))
    ax.set_xticks(range(k), ev.classes, rotation=40 if k <= CONFUSION_TEXT_MAX else 90,
                  ha="right" if k <= CONFUSION_TEXT_MAX else "center", fontsize=tick)
    ax.set_yticks(range(k), ev.classes, fontsize=tick)
    ax.set_xlabel("predicted")
    ax.set_ylabel("true")
    for i in range(k if k <= CONFUSION_TEXT_MAX else 0):
        for j in range(k):
            if cm[i, j]:
                ax.text(j, i, f"{100 * frac[i, j]:.0f}%\n({cm[i, j]})", ha="center",
                        va="center", fontsize=7, color="white" if frac[i, j] > 0.5
                        else "black")
    ax.set_title(title or f"accuracy {100 * ev.accuracy:.2f} % over {ev.n} {ev.unit}",
                 fontsize=9)
    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04, label="share of the true class")
    return save_png(fig, path)


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
