"""Measure contact reflexes on simulated touches with ground truth (:mod:`.physics.touch`).

The detectors of :mod:`fingertip.events.reflex` are fed as a live host would feed them, in
the order the data becomes available:

- audio in blocks of ``AUDIO_BLOCK`` samples (64 at 44.1 kHz, 1.45 ms: a small ALSA
  period), each available ``AUDIO_PATH_S`` after its last sample (USB isochronous transfer
  and driver: 1 ms, assumed; no sound card on this machine to measure);
- force frames at 15 or 80 Hz, each available after its bytes crossed the UART at the baud
  rate (:func:`wire_s`, from the real codec's frame length) plus ``DECODE_S``.

Latency = availability time of the data that produced the event - true contact time +
the measured wall-clock time of the detector call that produced it (this machine, noisy).
"""
from __future__ import annotations

import heapq
import time
from dataclasses import dataclass, field

import numpy as np

from fingertip.events.reflex import (
    ForceConfig,
    ForceOnlyContact,
    FusedConfig,
    FusedContact,
    OnsetDetector,
)
from fingertip.protocol.codec import encode
from fingertip.protocol.messages import Sample
from fingertip.sim.physics.touch import Session, force_frames, render_session

AUDIO_BLOCK = 64
AUDIO_PATH_S = 0.001
DECODE_S = 5e-5
"""Host decode of one frame (tests/bench/bench_decode.py measures a few microseconds)."""
BAUD = 115200
GATE_S = 0.08
MATCH_BEFORE_S = 0.01
MATCH_AFTER_S = 0.4


_block_cost: dict[float, float] = {}


def block_cost(fs: float, cfg: FusedConfig, seconds: float = 2.0) -> float:
    """Median wall-clock time (s) of feeding one AUDIO_BLOCK to an :class:`OnsetDetector`,
    measured once per process on noise."""
    if fs not in _block_cost:
        det = OnsetDetector(fs, cfg.onset)
        x = np.random.default_rng(0).standard_normal(int(seconds * fs)) * 1e-3
        costs = []
        for a in range(0, len(x) - AUDIO_BLOCK, AUDIO_BLOCK):
            c0 = time.perf_counter()
            det.feed(x[a:a + AUDIO_BLOCK], a / fs)
            costs.append(time.perf_counter() - c0)
        _block_cost[fs] = float(np.median(costs))
    return _block_cost[fs]


def wire_s(channels: int = 4, baud: int = BAUD) -> float:
    """Time on the wire of one sample frame (COBS, delimiter, 10 bits a byte)."""
    frame = encode(Sample(1, 123456, tuple([-3_000_000] * channels)))
    return len(frame) * 10 / baud


@dataclass
class SessionResult:
    contacts: np.ndarray
    """True contact times."""
    latency_s: list[float] = field(default_factory=list)
    """One per detected true contact (first ``contact`` event near it)."""
    sources: list[str] = field(default_factory=list)
    missed: int = 0
    false: int = 0
    """``contact`` events matching no true contact."""
    false_confirmed: int = 0
    """False ``contact`` events that were not retracted (force-sourced or confirmed)."""
    duration_s: float = 0.0


def run_session(session: Session, mode: str, rate_hz: float, *, audio: np.ndarray | None
                = None, channels: int = 4, baud: int = BAUD,
                cfg: FusedConfig | None = None, gate_s: float = GATE_S,
                wall_clock: bool = True) -> SessionResult:
    """Run one detector (``mode`` "fused" or "force") on a session. The hand tells the
    fused detector when its motor starts each move (``gate_s``, 0 for none).
    ``wall_clock=False`` leaves out the measured processing time (deterministic figures,
    for tests)."""
    cfg = cfg or FusedConfig()
    t_f, f_n = force_frames(session, rate_hz)
    delay = wire_s(channels, baud) + DECODE_S
    queue: list[tuple[float, int, str, object]] = []
    for i, (t, f) in enumerate(zip(t_f, f_n, strict=True)):
        queue.append((t + delay, i, "force", (t, f)))
    onset_cost = 0.0
    if mode == "fused":
        x = render_session(session) if audio is None else audio
        fs = session.fs
        det = FusedContact(fs, cfg)
        # The onset detector is causal and gives the same onsets for any block size
        # (tests check it), so it runs once over the session; each onset is known at the
        # end of its AUDIO_BLOCK block plus the audio path, and costs one block's work.
        onset_cost = block_cost(fs, cfg) if wall_clock else 0.0
        onsets = OnsetDetector(fs, cfg.onset)
        if gate_s:
            for t in session.motion_starts():
                onsets.gate(t, t + gate_s)
        for t, ratio in onsets.feed(x, 0.0):
            end = (int(t * fs) // AUDIO_BLOCK + 1) * AUDIO_BLOCK
            queue.append((end / fs + AUDIO_PATH_S, -len(queue), "onset", (t, ratio)))
    elif mode == "force":
        det = ForceOnlyContact(cfg.force)
    else:
        raise ValueError(f"mode must be fused or force, not {mode!r}")
    heapq.heapify(queue)
    events = []
    while queue:
        avail, _, kind, item = heapq.heappop(queue)
        c0 = time.perf_counter()
        if kind == "onset":
            got = det.feed_onsets([item], avail)
        else:
            got = det.feed_force(item[0], item[1], now=avail)
        cost = (time.perf_counter() - c0 if wall_clock else 0.0) \
            + (onset_cost if kind == "onset" else 0.0)
        events += [(e, cost) for e in got]
    return score(session, events)


def score(session: Session, events: list) -> SessionResult:
    truth = session.contact_s
    res = SessionResult(truth, duration_s=session.duration_s)
    contacts = [(e, c) for e, c in events if e.kind == "contact"]
    retracted = {e.time for e, _ in events if e.kind == "contact_retracted"}
    used = set()
    for tc in truth:
        hit = next(((i, e, c) for i, (e, c) in enumerate(contacts)
                    if i not in used and tc - MATCH_BEFORE_S <= e.time <= tc + MATCH_AFTER_S),
                   None)
        if hit is None:
            res.missed += 1
            continue
        i, e, c = hit
        used.add(i)
        res.latency_s.append(e.detected_at - tc + c)
        res.sources.append(e.source)
    for i, (e, _) in enumerate(contacts):
        if i in used:
            continue
        res.false += 1
        if e.time not in retracted:
            res.false_confirmed += 1
    return res


def summarise(results: list[SessionResult]) -> dict[str, float]:
    lat = np.concatenate([r.latency_s for r in results if r.latency_s] or [np.zeros(0)])
    minutes = sum(r.duration_s for r in results) / 60
    out = {
        "contacts": int(sum(len(r.contacts) for r in results)),
        "detected": int(lat.size),
        "missed": int(sum(r.missed for r in results)),
        "false": int(sum(r.false for r in results)),
        "false_confirmed": int(sum(r.false_confirmed for r in results)),
        "minutes": minutes,
        "piezo_share": float(np.mean([s == "piezo" for r in results for s in r.sources]))
        if lat.size else 0.0,
    }
    if lat.size:
        out.update(p50_ms=float(np.percentile(lat, 50) * 1e3),
                   p99_ms=float(np.percentile(lat, 99) * 1e3),
                   max_ms=float(lat.max() * 1e3))
    return out


__all__ = ["AUDIO_BLOCK", "AUDIO_PATH_S", "BAUD", "ForceConfig", "SessionResult",
           "run_session", "summarise", "wire_s"]
