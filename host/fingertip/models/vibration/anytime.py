"""Anytime classification: growing windows, running probabilities and early decisions.

A hand must decide during a slide, not after it. A ``growing`` model sees, at each
prediction time ``t``, the summary of everything heard since the start (up to a longest
span, after which the window slides): the longer the slide, the less noisy the estimate of
its spectrum, and the same model answers at 0.25 s and at 2 s. This module holds what does
not depend on a model: where the windows lie (:func:`growing_bounds`), the summary of a span
of log band power (:func:`span_features`), the running probabilities of a sequence of
predictions (:func:`running`) and the first moment a threshold is met (:func:`decide`).
Numpy only.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .features import STATS
from .window_features import log_window, pooled

DECISION_TIMES = (0.25, 0.5, 1.0, 2.0, None)
"""Seconds from the start at which accuracy is reported (None: the whole recording)."""


def growing_bounds(n_frames: int, frames: int, min_frames: int, step_frames: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """(start, end) frame indices of the windows of a recording of ``n_frames`` frames.

    Window ``j`` ends at ``min_frames + round(j * step_frames)`` and starts at 0 until it is
    ``frames`` long, then slides. The last window always ends at the last frame (the whole
    recording is always one of the answers). No window when ``n_frames < min_frames``.
    """
    if n_frames < max(1, min_frames):
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    n = int((n_frames - min_frames) / step_frames + 1e-9) + 1
    ends = min_frames + np.rint(np.arange(n) * step_frames).astype(np.intp)
    if ends[-1] != n_frames:
        ends = np.append(ends, n_frames)
    starts = np.maximum(0, ends - frames)
    return starts, ends


def training_bounds(n_frames: int, frames: int, min_frames: int, step_frames: float,
                    per_length: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Windows to train a growing model on: for each length from ``min_frames`` doubling
    up to ``frames`` (and the recording's own length if shorter), the prefix and up to
    ``per_length - 1`` more windows spread evenly over the recording. Prefixes are what the
    model sees at run time; the others add variety at little cost."""
    top = min(frames, n_frames)
    if top < max(1, min_frames):
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    lengths = []
    length = max(1, min_frames)
    while length < top:
        lengths.append(length)
        length *= 2
    lengths.append(top)
    st, en = [], []
    for length in lengths:
        room = n_frames - length
        k = 1 if room < step_frames else per_length
        for s in np.unique(np.rint(np.linspace(0, room, k)).astype(np.intp)):
            st.append(int(s))
            en.append(int(s) + length)
    return np.array(st, np.intp), np.array(en, np.intp)


def span_features(power: np.ndarray, starts: np.ndarray, ends: np.ndarray,
                  floor_db: float, stats: Sequence[str] = STATS, split: int = 0
                  ) -> np.ndarray:
    """(windows, len(stats) x bands): the gain-free summary of ``power[start:end]`` for
    each window (:func:`~fingertip.models.vibration.window_features.pooled` of
    :func:`~fingertip.models.vibration.window_features.log_window`, ``split`` as there)."""
    nb = power.shape[1]
    out = np.empty((len(starts), len(stats) * nb), dtype=power.dtype)
    for i, (s, e) in enumerate(zip(starts, ends, strict=True)):
        out[i] = pooled(log_window(power[s:e], floor_db, split), stats)
    return out


def running(probs: np.ndarray, growing: np.ndarray | None = None) -> np.ndarray:
    """Running class probabilities after each prediction.

    ``growing[i]`` tells whether window ``i`` still starts at the beginning (it then
    summarises everything so far: its own probabilities are the running ones); once windows
    slide, the running probabilities are the mean of the sliding windows' so far. Without
    ``growing``: the cumulative mean of every window's probabilities.
    """
    p = np.asarray(probs, np.float64)
    if not len(p):
        return p.copy()
    if growing is None:
        growing = np.zeros(len(p), bool)
    out = np.empty_like(p)
    acc = np.zeros(p.shape[1])
    n = 0
    for i in range(len(p)):
        if growing[i]:
            out[i] = p[i]
        else:
            acc += p[i]
            n += 1
            out[i] = acc / n
    return out


@dataclass
class Decision:
    """The first moment the running probability of one class reached a threshold."""

    label: str | None
    """The class, or None when the threshold was never met (or the answer is unknown)."""
    probability: float
    t: float
    """Seconds from the start when it was met (the end of the last window heard); the end
    of the recording when never met."""
    decided: bool

    def to_dict(self) -> dict:
        return {"label": self.label, "probability": round(self.probability, 4),
                "t": round(self.t, 4), "decided": self.decided}


def decide(run: np.ndarray, t_end: np.ndarray, classes: Sequence[str], threshold: float
           ) -> Decision:
    """The first running prediction whose top probability is ``threshold`` or more; when
    none is, the last one (``decided`` False)."""
    if not 0 < threshold <= 1:
        raise ValueError("the decision threshold must be in (0, 1]")
    run = np.asarray(run)
    if not len(run):
        return Decision(None, math.nan, math.nan, False)
    top = run.max(axis=1)
    hit = np.flatnonzero(top >= threshold)
    i = int(hit[0]) if len(hit) else len(run) - 1
    k = int(np.argmax(run[i]))
    return Decision(classes[k], float(run[i, k]), float(t_end[i]), bool(len(hit)))


def at_time(run: np.ndarray, t_end: np.ndarray, t: float | None) -> np.ndarray | None:
    """The running probabilities available at ``t`` seconds (the last prediction whose
    window ended by then, with a 1 ms tolerance); None before the first. ``t`` None: the
    end."""
    if not len(run):
        return None
    if t is None:
        return run[-1]
    i = np.flatnonzero(np.asarray(t_end) <= t + 1e-3)
    return run[i[-1]] if len(i) else None


def time_label(t: float | None) -> str:
    return "whole" if t is None else f"{t:g} s"
