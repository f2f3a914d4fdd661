"""Windows of a recording's spectrogram and the features a model takes from them (pooled
summaries, spectrogram windows or growing windows)."""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..features import STATS, FeatureConfig, Recording, clipped_mask
from ..spectrogram import Spectrogrammer
from ..window_features import gather_windows, log_window, pooled, window_starts

INPUTS = ("pooled", "spectrogram", "growing")


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
        n = self.cfg.total_bands
        if self.spec.input == "spectrogram":
            return (self.spec.frames, n)
        return (len(self.spec.stats) * n,)

    def span_s(self) -> float:
        """Seconds of audio one window needs."""
        return (self.spec.frames - 1) * self.cfg.hop_s + self.cfg.win_s

    def windows(self, rec: Recording, training: bool = False,
                power: np.ndarray | None = None, prefixes: bool = False) -> Windows:
        """The windows of ``rec``; ``training``: for a growing model, the windows it is
        trained on (:func:`~fingertip.models.vibration.anytime.training_bounds`) instead of the
        ones it answers on. ``power``: ``rec``'s band power under this pipeline's
        features, computed already (:meth:`power`; a trainer shares it between uses).
        ``prefixes``: of a growing model's windows, only those from the start (what it
        answers on at run time; an augmented copy's training windows), not computed at
        all for the others."""
        cfg, sp = self.cfg, self.spec
        if power is None:
            power = self.power(rec)
        if sp.input == "growing":
            return self._growing(rec, power, training, prefixes)
        starts = window_starts(len(power), sp.frames, sp.step_s, cfg.hop_s)
        frames = sp.frames
        if not len(starts) and sp.input == "pooled" and sp.min_frames \
                and len(power) >= sp.min_frames:
            starts, frames = np.zeros(1, dtype=np.intp), len(power)
        logw = log_window(gather_windows(power, starts, frames), cfg.floor_db, cfg.split)
        inputs = pooled(logw, sp.stats) if sp.input == "pooled" else logw
        t0 = starts * cfg.hop_s
        t1 = t0 + (frames - 1) * cfg.hop_s + cfg.win_s
        lv, cl = _window_stats(rec, t0, t1)
        return Windows(inputs, t0, t1, lv, cl)

    def power(self, rec: Recording, lines: Sequence[float] | None = None) -> np.ndarray:
        """(frames, bands) band power of ``rec`` under this pipeline's features
        (``lines``: its mains lines, found already; see the :class:`Spectrogrammer`)."""
        return self.spectro(rec.samples, rec.rate, rec.source or "the recording", lines)

    def _growing(self, rec: Recording, power: np.ndarray, training: bool,
                 prefixes: bool = False) -> Windows:
        from ..anytime import growing_bounds, span_features, training_bounds

        cfg, sp = self.cfg, self.spec
        bounds = training_bounds if training else growing_bounds
        starts, ends = bounds(len(power), sp.frames, sp.min_frames or 1, sp.step_s / cfg.hop_s)
        if prefixes:
            starts, ends = starts[starts == 0], ends[starts == 0]
        inputs = span_features(power, starts, ends, cfg.floor_db, sp.stats, cfg.split)
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
