"""What the steps of one material training share (:class:`TrainingRun`), what the final fit
gives (:class:`Final`), what a training returns (:class:`TrainResult`) and the evaluation
of its answers: apart from :mod:`.material` (the steps) and :mod:`.material_report` (the
outputs), so that neither has to import the other."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .bank import Bank
from .candidates import Candidate
from .classify import Dataset, ModelEvaluation, evaluate
from .cross_validation import FitMemo
from .progress import Bars
from .scores import Answers
from .setup import Setup


@dataclass
class TrainResult:
    out: Path
    model_path: Path
    evaluation: ModelEvaluation
    report: dict
    files: list[Path] = field(default_factory=list)
    model: object = None
    """The trained model (float64 reference of the exported ONNX graph, before the
    temperature)."""


@dataclass
class TrainingRun:
    """What the steps of one training share."""

    ds: Dataset
    setup: Setup
    labels: np.ndarray
    folds: list[np.ndarray]
    """The cross-validation's test sets (of the training recordings)."""
    train_idx: np.ndarray
    test_idx: np.ndarray
    seed: int
    jobs: int
    bars: Bars
    memo: FitMemo = field(default_factory=FitMemo)
    bank: Bank | None = None
    cands: list[Candidate] = field(default_factory=list)
    results: dict[str, dict] = field(default_factory=dict)
    skipped: dict[str, str] = field(default_factory=dict)
    oof: dict[str, dict[int, Answers]] = field(default_factory=dict)
    timing: dict[str, float] = field(default_factory=dict)

    @property
    def classes(self) -> list[str]:
        return self.ds.classes


@dataclass
class Final:
    """The exported model and what the evaluation needs of it."""

    fitted: object
    novelty: object
    answers: dict[int, Answers]
    """Out-of-fold answers of the chosen candidate (uncalibrated)."""
    temps: list[float]
    temperature: float
    evaluated: dict[int, Answers]
    """The answers the evaluation scores (calibrated)."""
    seconds: float


def evaluation_of(ans: dict[int, Answers], labels: np.ndarray, classes: list[str]
                  ) -> ModelEvaluation:
    """Per window and per recording (its answer after the whole recording)."""
    wt, wp, rt, rp = [], [], [], []
    per = {}
    for i, a in ans.items():
        hit = a.probs.argmax(axis=1)
        wt += [int(labels[i])] * len(hit)
        wp += hit.tolist()
        rt.append(int(labels[i]))
        rp.append(int(np.argmax(a.run[-1])))
        per[i] = float(np.mean(hit == labels[i]))
    return ModelEvaluation(evaluate(wt, wp, classes, "windows"),
                           evaluate(rt, rp, classes, "recordings"), per)

