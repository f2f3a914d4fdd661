"""Contact and vibration events from signals. Pure numpy: arrays in, events out.

- :func:`contact_intervals`: make and break of contact from force-channel counts, with a
  threshold set from the signal's own noise (a multiple of a robust noise estimate) and
  hysteresis so that noise near the threshold does not chatter.
- :func:`vibration_onsets`: the paper's edge detector for cup rims: short-time RMS envelope,
  threshold, binarisation, temporal clustering with a gap tolerance, onset of each cluster.
  The threshold comes from the recording itself (the noise floor's median and spread), so
  one recording's level does not fix it for all.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, slots=True)
class Event:
    """An event at ``time`` (the caller's time base: seconds, or device microseconds)."""

    time: float
    kind: str
    value: float = 0.0


def robust_sigma(x: np.ndarray) -> float:
    """Noise level from the median absolute deviation (immune to the events themselves)."""
    x = np.asarray(x, dtype=np.float64)
    if x.size == 0:
        return 0.0
    return float(1.4826 * np.median(np.abs(x - np.median(x))))


def _check_finite(name: str, x: np.ndarray) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return x


def contact_intervals(t: np.ndarray, counts: np.ndarray, *, k_on: float = 20.0,
                      k_off: float = 10.0, release_fraction: float = 0.15,
                      track_s: float = 0.3, settle_s: float = 0.2, baseline_s: float = 0.3,
                      min_sigma: float = 1.0) -> list[Event]:
    """Contact make/break events from force channels (``counts``: frames x channels, tared or
    not; ``t``: frame times in seconds).

    Out of contact, a zero follows the signal with time constant ``track_s``, so slow drift
    (creep recovering after a release, temperature) is not taken for contact; in contact the
    zero holds. Contact is made when the change from the zero exceeds ``k_on`` times the
    noise (estimated from the first ``baseline_s``), and breaks below ``k_off`` times the
    noise or ``release_fraction`` of the contact's peak, whichever is higher: hysteresis and
    creep of the prism leave a residue after unloading that is far above the noise. For
    ``settle_s`` after a break the zero is the signal itself (the end of the unloading).
    """
    t = _check_finite("t", t)
    c = _check_finite("counts", np.atleast_2d(counts))
    if c.shape[0] != t.shape[0]:
        c = c.T
    if c.shape[0] != t.shape[0]:
        raise ValueError("counts must have one row per time")
    if t.size < 3:
        return []
    base_n = max(3, int(np.searchsorted(t, t[0] + baseline_s)))
    sigma = max(float(np.median([robust_sigma(np.diff(c[:base_n, j]))
                                 for j in range(c.shape[1])])) / np.sqrt(2), min_sigma)
    on, off = k_on * sigma, k_off * sigma
    zero = c[:base_n].mean(axis=0)
    events: list[Event] = []
    inside = False
    peak = 0.0
    settle_until = -np.inf
    for i in range(t.size):
        if not inside and t[i] < settle_until:
            zero = c[i].copy()
        m = float(np.linalg.norm(c[i] - zero))
        if not inside:
            if m > on:
                inside, peak = True, m
                events.append(Event(float(t[i]), "contact_make", m))
            elif i:
                a = min(1.0, (t[i] - t[i - 1]) / track_s)
                zero += a * (c[i] - zero)
        else:
            peak = max(peak, m)
            if m < max(off, release_fraction * peak):
                inside = False
                zero = c[i].copy()
                settle_until = t[i] + settle_s
                events.append(Event(float(t[i]), "contact_break", m))
    return events


def rms_envelope(x: np.ndarray, fs: float, window_s: float = 0.002) -> tuple[np.ndarray, float]:
    """Root-mean-square over consecutive windows; returns (envelope, envelope rate in Hz)."""
    x = _check_finite("audio", x)
    if x.ndim > 1:
        x = x.mean(axis=1)
    n = max(1, int(round(window_s * fs)))
    m = x.size // n
    if m == 0:
        return np.zeros(0), fs / n
    frames = x[: m * n].reshape(m, n)
    return np.sqrt(np.mean(frames * frames, axis=1)), fs / n


def vibration_onsets(x: np.ndarray, fs: float, *, window_s: float = 0.002,
                     k: float = 6.0, gap_s: float = 0.2, min_len_s: float = 0.004,
                     threshold: float | None = None, t0: float = 0.0) -> list[Event]:
    """Onsets of vibration bursts (cup rims, taps): threshold the RMS envelope, binarise,
    merge bursts closer than ``gap_s``, drop clusters shorter than ``min_len_s``.

    The threshold is ``threshold`` if given, else the envelope's median plus ``k`` robust
    standard deviations (the floor: most of any recording is between events). ``t0`` is the
    time of sample 0; event times are ``t0 + seconds``; ``value`` is the cluster's peak RMS.
    """
    env, rate = rms_envelope(x, fs, window_s)
    if env.size == 0:
        return []
    thr = threshold if threshold is not None else \
        float(np.median(env) + k * max(robust_sigma(env), 1e-12))
    above = env > thr
    idx = np.flatnonzero(above)
    if idx.size == 0:
        return []
    gap = max(1, int(round(gap_s * rate)))
    # Clusters: runs of above-threshold windows whose gaps are shorter than the tolerance.
    breaks = np.flatnonzero(np.diff(idx) > gap)
    starts = np.concatenate(([idx[0]], idx[breaks + 1]))
    ends = np.concatenate((idx[breaks], [idx[-1]]))
    min_len = max(1, int(round(min_len_s * rate)))
    out = []
    for s, e in zip(starts, ends, strict=True):
        if e - s + 1 < min_len and env[s:e + 1].max() < 2 * thr:
            continue
        out.append(Event(t0 + s / rate, "vibration_onset", float(env[s:e + 1].max())))
    return out


def heights_at(events: list[Event], t: np.ndarray, z: np.ndarray) -> list[tuple[Event, float]]:
    """Each event with the robot's height at its time, interpolated in the robot's own log
    of (time, z) on the same clock (e.g. the host clock the bridge maps frames onto)."""
    t = _check_finite("robot times", t)
    z = _check_finite("robot heights", z)
    if t.size < 2 or t.size != z.size:
        raise ValueError("need at least two (time, z) samples of the robot, as many of each")
    if np.any(np.diff(t) <= 0):
        raise ValueError("robot times must increase")
    out = []
    for e in events:
        if not t[0] <= e.time <= t[-1]:
            raise ValueError(f"event at {e.time:.3f} s lies outside the robot's log "
                             f"({t[0]:.3f}..{t[-1]:.3f} s)")
        out.append((e, float(np.interp(e.time, t, z))))
    return out


def refine_contacts(force_events: list[Event], vibration_events: list[Event], *,
                    before_s: float = 0.05, after_s: float = 0.02) -> list[Event]:
    """Contact events from force, timed by vibration where the piezo heard them.

    A force frame comes every 12.5 ms at best, the piezo every 23 us: a contact make or break
    found in the force channels takes the time of a vibration onset from ``before_s`` before
    it to ``after_s`` after it, when there is one (``detail`` of the kind says which)."""
    onsets = np.array(sorted(e.time for e in vibration_events))
    out = []
    for e in force_events:
        if onsets.size:
            i = int(np.searchsorted(onsets, e.time - before_s))
            if i < onsets.size and onsets[i] <= e.time + after_s:
                out.append(Event(float(onsets[i]), e.kind, e.value))
                continue
        out.append(e)
    return out
