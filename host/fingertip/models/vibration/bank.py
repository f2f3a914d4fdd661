"""The material trainer's features, computed once per recording and shared.

Every growing-window candidate (:mod:`.candidates`) reads columns of one set of features:
the log bands and the baseline's linear bins of one short-time spectrum per recording,
summarised over each window by :data:`~.candidates.BANK_STATS` (mean, deviation and
frame-to-frame change of every column; 90th percentile of the log bands). Each statistic
of each band is computed the way the candidate's own pipeline computes it at run time
(each view normalised on its own: :func:`~.window_features.log_window`'s ``split``), so a
candidate's columns equal its own features up to float32 rounding of the shared band
matrix (a test checks it). The CNN's spectrogram windows come from the same spectrum's log
bands. The trials (the mains notch,
augmented copies) build their own bank once and share it the same way.
"""
from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from .augment import NONE as NO_AUGMENT
from .augment import AugmentConfig, augmented
from .candidates import BANK_STATS, Candidate, bank_config
from .classify import Dataset, FeaturePipeline, Windows
from .features import CANONICAL_RATE, Recording
from .parallel import run_rounds, shared
from .setup import Setup

log = logging.getLogger(__name__)


@dataclass
class CandidateWindows:
    """Every recording's training windows and the windows it is answered on."""

    train: Sequence[Windows]
    test: Sequence[Windows]
    seconds: float
    token: str = ""
    """Names the features these windows come from (a fit on the same rows of the same
    token is the same fit: :class:`~.cross_validation.FitMemo`)."""


class _Columns(Sequence):
    """A recording's windows with the inputs cut to some columns, made when read."""

    def __init__(self, windows: Sequence[Windows], cols: np.ndarray) -> None:
        self.windows, self.cols = windows, cols

    def __len__(self) -> int:
        return len(self.windows)

    def __getitem__(self, i):  # type: ignore[override]
        w = self.windows[i]
        return replace(w, inputs=w.inputs[:, self.cols])


@dataclass
class Bank:
    """The shared features of every recording of a dataset (see the module text)."""

    pipe: FeaturePipeline
    p90: FeaturePipeline
    train: list[Windows]
    test: list[Windows]
    seconds: float
    token: str
    own: dict[str, CandidateWindows] = field(default_factory=dict)
    """Windows of the candidates that do not read the shared columns (the CNN)."""

    def view(self, cand: Candidate) -> CandidateWindows:
        """``cand``'s windows: its columns of the shared features (or its own)."""
        if cand.cols is None:
            return self.own[cand.name]
        return CandidateWindows(_Columns(self.train, cand.cols),
                                _Columns(self.test, cand.cols), self.seconds, self.token)


def bank_pipeline(setup: Setup) -> FeaturePipeline:
    """The shared windows' first statistics (:data:`~.candidates.BANK_STATS` but the
    last) over every column."""
    return FeaturePipeline(bank_config(setup.cfg), setup.spec(BANK_STATS[:-1]))


def p90_pipeline(setup: Setup) -> FeaturePipeline:
    """The last statistic (the 90th percentile) over the log bands only: the candidates
    that read it read no other (a percentile costs more than the other three together)."""
    return FeaturePipeline(setup.cfg, setup.spec(BANK_STATS[-1:]))


def _shared(pipe: FeaturePipeline, p90: FeaturePipeline, rec: Recording, training: bool,
            power: np.ndarray, prefixes: bool = False) -> Windows:
    w = pipe.windows(rec, training, power, prefixes)
    q = p90.windows(rec, training, power[:, :p90.cfg.n_bands], prefixes)
    return replace(w, inputs=np.hstack([w.inputs, q.inputs]))


CHUNK = 25
"""Recordings per job when the features are computed in worker processes."""


def _chunk_job(key: str, lo: int, hi: int) -> list:
    """In a worker: the per-recording function shared under ``key`` on ``lo..hi-1``."""
    fn = shared(key)
    return [fn(i) for i in range(lo, hi)]


def per_recording(key: str, fn: Callable[[int], object], n: int, jobs: int,
                  done: Callable[[], None] | None = None) -> list:
    """``[fn(i) for i in range(n)]``, in chunks of :data:`CHUNK` recordings on ``jobs``
    worker processes (each recording's result depends on it alone, so the same)."""
    if jobs <= 1:
        out = []
        for i in range(n):
            out.append(fn(i))
            if done is not None:
                done()
        return out

    def tick() -> None:  # a chunk is done
        for _ in range(CHUNK):
            done()

    chunks = [(key, lo, min(n, lo + CHUNK)) for lo in range(0, n, CHUNK)]
    parts = run_rounds(_chunk_job, chunks, jobs, {key: fn},
                       done=tick if done is not None else None)
    return [r for part in parts for r in part]


def build_bank(setup: Setup, ds: Dataset, cands: Sequence[Candidate], token: str,
               done: Callable[[], None] | None = None, jobs: int = 1,
               lines: Sequence[Sequence[float]] | None = None,
               clean: Bank | None = None) -> Bank:
    """One short-time spectrum per recording of ``ds``; its shared windows, and the own
    windows of the candidates of ``cands`` without columns (from the same spectrum).
    ``jobs``: worker processes (the recordings are independent). With features that notch
    mains lines: ``lines``, every recording's lines when found already (not searched
    again), and ``clean``, the bank of the same features without the notch, whose windows
    the recordings without lines take (the notch leaves them as they are: the same
    samples, the same windows); ``done`` then ticks for the others only."""
    t0 = time.perf_counter()
    pipe, p90 = bank_pipeline(setup), p90_pipeline(setup)
    nb = setup.cfg.n_bands
    others = [c for c in cands if c.cols is None]
    n = len(ds.items)
    reuse = lines is not None and clean is not None and setup.cfg.mains_notch \
        and all(c.name in clean.own for c in others)
    todo = [i for i in range(n) if lines[i]] if reuse else list(range(n))

    def one(k: int) -> tuple:
        i = todo[k]
        rec = ds.items[i].rec
        power = pipe.power(rec, None if lines is None else lines[i])
        # log bands only for the others: the spectrum's first columns
        return (_shared(pipe, p90, rec, True, power), _shared(pipe, p90, rec, False, power),
                [(c.pipe.windows(rec, True, power[:, :nb]),
                  c.pipe.windows(rec, power=power[:, :nb])) for c in others])

    made = dict(zip(todo, per_recording("bank", one, len(todo), jobs, done), strict=True))
    got = [made[i] if i in made else
           (clean.train[i], clean.test[i],
            [(clean.own[c.name].train[i], clean.own[c.name].test[i]) for c in others])
           for i in range(n)]
    train = [g[0] for g in got]
    test = [g[1] for g in got]
    secs = time.perf_counter() - t0
    own = {c.name: CandidateWindows([g[2][k][0] for g in got], [g[2][k][1] for g in got],
                                    secs, token) for k, c in enumerate(others)}
    return Bank(pipe, p90, train, test, secs, token, own)


def with_copies(bank: Bank, ds: Dataset, augment: AugmentConfig, seed: int,
                cands: Sequence[Candidate] = (),
                done: Callable[[], None] | None = None, jobs: int = 1) -> Bank:
    """``bank`` with the training windows of ``augment.copies`` augmented copies of every
    recording added (reproducible from ``seed`` and the recording's index; the answered
    windows stay clean). Of a copy, only what the model answers at run time is kept (the
    windows from the start; all of a spectrogram model's): the copies teach invariance at
    a third of the rows. ``jobs``: worker processes."""
    t0 = time.perf_counter()
    pipe = bank.pipe
    nb = pipe.cfg.n_bands
    others = [c for c in cands if c.cols is None]

    def one(i: int) -> tuple:
        it = ds.items[i]
        copies = augmented(it.rec, augment, [seed, i], pipe.cfg.canonical_rate) \
            if augment.copies and len(bank.train[i]) else []
        parts = [bank.train[i]]
        own = [[bank.own[c.name].train[i]] for c in others]
        for r in copies:
            power = pipe.power(r)
            # only the windows kept are computed (one of up to three per length)
            parts.append(_prefixes(_shared(pipe, bank.p90, r, True, power, prefixes=True)))
            for k, c in enumerate(others):
                own[k].append(_prefixes(c.pipe.windows(r, True, power[:, :nb],
                                                       prefixes=True)))
        return _concat(parts), [_concat(v) for v in own]

    got = per_recording("copies", one, len(ds.items), jobs, done)
    secs = bank.seconds + time.perf_counter() - t0
    token = f"{bank.token}+{augment.to_dict()}+{seed}"
    own = {c.name: CandidateWindows([g[1][k] for g in got], bank.own[c.name].test, secs,
                                    token) for k, c in enumerate(others)}
    return Bank(pipe, bank.p90, [g[0] for g in got], bank.test, secs, token, own)


_FIELDS = ("inputs", "t_start", "t_end", "level_db", "clipped")


def _prefixes(w: Windows) -> Windows | None:
    keep = w.growing if w.growing is not None else np.ones(len(w), bool)
    if not keep.any():  # a copy too short for one window (sped up) adds nothing
        return None
    return Windows(*(getattr(w, f)[keep] for f in _FIELDS),
                   None if w.growing is None else w.growing[keep])


def _concat(ws: list[Windows | None]) -> Windows:
    ws = [w for w in ws if w is not None]
    if len(ws) == 1:
        return ws[0]
    return Windows(*(np.concatenate([getattr(w, f) for w in ws]) for f in _FIELDS),
                   None if ws[0].growing is None else np.concatenate([w.growing for w in ws]))


# --- a candidate's own windows, without the bank (tools and tests) ------------------------

def band_powers(pipe: FeaturePipeline, ds: Dataset) -> list[np.ndarray]:
    """Every recording's band power under ``pipe``'s features."""
    return [pipe.power(it.rec) for it in ds.items]


def augmented_copies(ds: Dataset, augment: AugmentConfig, seed: int = 0,
                     canonical: int = CANONICAL_RATE) -> list[list[Recording]]:
    """The augmented copies of every recording of ``ds`` (reproducible from ``seed`` and
    the recording's index), at the features' working rate."""
    return [augmented(it.rec, augment, [seed, i], canonical) if augment.copies else []
            for i, it in enumerate(ds.items)]


def candidate_windows(cand: Candidate, ds: Dataset, augment: AugmentConfig = NO_AUGMENT,
                      seed: int = 0, copies: list[list[Recording]] | None = None,
                      clean: CandidateWindows | None = None,
                      powers: Sequence[np.ndarray] | None = None) -> CandidateWindows:
    """``cand``'s windows computed with its own pipeline (what it sees at run time), with
    those of ``augment.copies`` augmented copies of each recording (``copies``: made
    already by :func:`augmented_copies`) added to the training windows. ``clean``: its
    windows without augmentation, computed already (only the copies' are computed);
    ``powers``: every recording's band power under its features. The trainer uses the
    shared :class:`Bank` instead; this is the reference the bank is checked against."""
    t0 = time.perf_counter()
    if copies is None:
        copies = augmented_copies(ds, augment, seed, cand.pipe.cfg.canonical_rate)
    if clean is not None:
        tr = [_concat([w, *(_prefixes(cand.pipe.windows(r, training=True)) for r in extra)])
              if len(w) else w for extra, w in zip(copies, clean.train, strict=True)]
        te = clean.test
    else:
        if powers is None:
            powers = band_powers(cand.pipe, ds)
        tr, te = [], []
        for it, extra, pw in zip(ds.items, copies, powers, strict=True):
            w = cand.pipe.windows(it.rec, True, pw)
            tr.append(_concat([w, *(_prefixes(cand.pipe.windows(r, training=True))
                                    for r in extra)]) if len(w) else w)
            te.append(cand.pipe.windows(it.rec, power=pw))
    short = [ds.rel(it) for it, w in zip(ds.items, te, strict=True) if not len(w)]
    if short:
        log.warning("%d recording(s) shorter than the first window give no answer: %s",
                    len(short), ", ".join(short[:5]))
    return CandidateWindows(tr, te, time.perf_counter() - t0)
