"""How good and how fast a fitted map is: RMSE (overall, by angle, by height), latency in
onnxruntime, float32 error against the float64 reference at the ADC's extremes."""
from __future__ import annotations

import math
import statistics
import time
from pathlib import Path

import numpy as np

from ....protocol import INT24_MAX, INT24_MIN
from ...nets.onnx_io import open_session
from .data import CalibrationData
from .limits import CHANNELS


def rmse(pred: np.ndarray, force: np.ndarray) -> float:
    """Vector RMSE in N: sqrt(mean |pred - force|^2)."""
    d = np.asarray(pred, np.float64) - np.asarray(force, np.float64)
    return float(np.sqrt(np.mean(np.sum(d * d, axis=1)))) if len(d) else math.nan


def _by(keys: np.ndarray, pred: np.ndarray, force: np.ndarray) -> dict[str, float]:
    out = {}
    ok = np.array([k == k and k != "" for k in keys], bool)  # drops NaN and ''
    for k in sorted(set(keys[ok].tolist())):
        sel = keys == k
        label = f"{k:g}" if isinstance(k, float) else str(k)
        out[label] = round(rmse(pred[sel], force[sel]), 5)
    return out


def angle_keys(data: CalibrationData, step_deg: float = 10.0) -> np.ndarray:
    """Angles for the by-angle table: the recorded ones, or else the direction of the
    reference force rounded to ``step_deg`` (NaN for forces under 5 % of the largest)."""
    if np.all(np.isfinite(data.angle_deg)):
        return data.angle_deg
    mag = np.hypot(data.force[:, 0], data.force[:, 1])
    ang = np.degrees(np.arctan2(data.force[:, 1], data.force[:, 0]))
    out = np.round(ang / step_deg) * step_deg + 0.0
    out[mag < 0.05 * max(mag.max(), 1e-12)] = np.nan
    return out


def measure_latency(paths: dict[str, Path] | str | Path, sample: np.ndarray, *,
                    single_calls: int = 2000, batch: int = 1000, batch_repeats: int = 30):
    """Median microseconds per estimate with onnxruntime (one thread): one frame per call
    (``single_calls`` timed calls per model) and a batch of ``batch`` frames (per frame,
    ``batch_repeats`` calls).

    Several models are timed call by call in turn, each leading in rotation, so that a
    machine getting busier or quieter weighs on all of them alike. (Timed a stretch of calls
    at a time, two equally fast models came out 8 % apart on a busy 2-core machine, which
    decided the calibration's choice.)

    ``paths``: {name: path} -> {name: (single_us, batch_us)}; one path -> (single, batch).
    """
    one_path = not isinstance(paths, dict)
    named = {"model": Path(paths)} if one_path else {k: Path(v) for k, v in paths.items()}
    x = np.asarray(sample, np.float32)
    one = np.ascontiguousarray(x[:1])
    many = np.ascontiguousarray(np.resize(x, (batch, x.shape[1])))
    sessions = []
    for name, path in named.items():
        sess = open_session(path)
        inp = sess.get_inputs()[0].name
        for _ in range(100):
            sess.run(None, {inp: one})
        sess.run(None, {inp: many})
        sessions.append((name, sess, inp))
    single = _interleaved(sessions, one, single_calls)
    batched = _interleaved(sessions, many, batch_repeats)
    res = {k: (statistics.median(single[k]) / 1e3, statistics.median(batched[k]) / 1e3 / batch)
           for k in named}
    return res["model"] if one_path else res


def _interleaved(sessions: list, feed: np.ndarray, calls: int) -> dict[str, list[int]]:
    """Nanoseconds of ``calls`` runs of each session on ``feed``, one call of each in turn."""
    clock = time.perf_counter_ns
    times: dict[str, list[int]] = {name: [] for name, _, _ in sessions}
    n = len(sessions)
    for i in range(calls):
        for j in range(n):
            name, sess, inp = sessions[(i + j) % n]
            t0 = clock()
            sess.run(None, {inp: feed})
            times[name].append(clock() - t0)
    return times


def extreme_inputs(seed: int = 0, random_rows: int = 200) -> np.ndarray:
    """Counts at the 24-bit limits: every corner of {-2^23, 0, 2^23-1}^4 and random rows."""
    vals = np.array([INT24_MIN, 0, INT24_MAX], np.float64)
    grid = np.stack(np.meshgrid(*[vals] * CHANNELS, indexing="ij"), -1).reshape(-1, CHANNELS)
    rnd = np.random.default_rng(seed).integers(INT24_MIN, INT24_MAX + 1,
                                               (random_rows, CHANNELS)).astype(np.float64)
    return np.concatenate([grid, rnd])


def float32_error(path: str | Path, model, counts: np.ndarray) -> tuple[float, float]:
    """(max |ONNX float32 - float64 reference| in N on ``counts``, max of the same relative
    to max(|reference|, 1 N) on :func:`extreme_inputs`)."""
    sess = open_session(Path(path))
    name = sess.get_inputs()[0].name

    def run(x):
        return sess.run(None, {name: np.asarray(x, np.float32)})[0].astype(np.float64)

    x = np.asarray(counts, np.float64)
    in_range = float(np.max(np.abs(run(x) - model.predict(x)))) if len(x) else 0.0
    ext = extreme_inputs()
    ref = model.predict(ext)
    rel = np.abs(run(ext) - ref) / np.maximum(np.abs(ref), 1.0)
    return in_range, float(np.max(rel))
