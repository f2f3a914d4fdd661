"""Slip of a held object, from each fingertip's vibration and its force ratio.

While an object is held, a fingertip's piezo is quiet (the hand is still, nothing is made or
broken); the rim of the contact patch slipping (micro-slip) and then the object sliding
(stick-slip) give short bursts. :class:`SlipDetector` emits ``slip_onset`` on

- a piezo onset on any holding finger (``source`` "piezo"), from a
  :class:`~.reflex.OnsetDetector` per finger, gated by the hand while it moves its own
  fingers (:meth:`SlipDetector.motion`), or
- the force ratio: the tangential over the normal force (smoothed over about two frames)
  rising by ``ratio_rise`` above its lowest level since the hold began or the last event,
  or one frame's ratio jumping by ``ratio_step`` (``source`` "force"): the load grew. A
  sliding object cannot pull harder than the kinetic friction, so the ratio rises only up to
  mu_k: a grip with a margin sees a small rise, which is why force alone detects slip late.

Events closer than ``refractory_s`` to the
previous one are merged, so a reflex raises the
grip once per slip burst, not once per stick-slip pulse. ``mode`` "force" ignores the piezo
(the force-only baseline).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .reflex import Callback, OnsetConfig, OnsetDetector, ReflexEvent


@dataclass
class SlipConfig:
    ratio_rise: float = 0.1
    """Slip when the smoothed ratio exceeds its reference by this much ..."""
    ratio_step: float = 0.15
    """... or one frame's ratio exceeds the smoothed one by this much."""
    smooth: float = 0.5
    """Weight of the newest frame in the smoothed ratio (force estimates scatter by a few
    hundredths from frame to frame)."""
    refractory_s: float = 0.03
    min_normal_n: float = 0.05
    """Below this normal force the ratio means nothing (not holding)."""
    onset: OnsetConfig = field(default_factory=OnsetConfig)


class SlipDetector:
    """Slip onsets of the fingers ``fingers`` (see the module text)."""

    def __init__(self, fingers: Sequence[str], fs: float, cfg: SlipConfig | None = None,
                 mode: str = "fused", callbacks: list[Callback] | None = None) -> None:
        if mode not in ("fused", "force"):
            raise ValueError(f"mode must be fused or force, not {mode!r}")
        self.cfg = cfg or SlipConfig()
        self.mode = mode
        self.fingers = list(fingers)
        self.onsets = {f: OnsetDetector(fs, self.cfg.onset) for f in self.fingers}
        self.callbacks: list[Callback] = list(callbacks or [])
        self._ratio0: dict[str, float] = {}
        self._ratio: dict[str, float] = {}
        self._last = -math.inf
        self.events: list[ReflexEvent] = []

    def motion(self, t: float, guard_s: float = 0.08) -> None:
        """The hand starts moving its fingers at ``t`` (a grip correction): gate the piezos."""
        for d in self.onsets.values():
            d.gate(t, t + guard_s)

    def _emit(self, t: float, now: float, source: str, value: float) -> list[ReflexEvent]:
        if t - self._last < self.cfg.refractory_s:
            return []
        self._last = t
        ev = ReflexEvent("slip_onset", t, now, source, value)
        self.events.append(ev)
        for cb in self.callbacks:
            cb(ev)
        return [ev]

    def feed_audio(self, finger: str, samples: np.ndarray, t0: float,
                   now: float | None = None) -> list[ReflexEvent]:
        det = self.onsets[finger]
        now = t0 + len(samples) / det.fs if now is None else now
        onsets = det.feed(samples, t0)
        if self.mode == "force":
            return []
        out = []
        for t, ratio in onsets:
            out += self._emit(t, now, "piezo", ratio)
        return out

    def feed_force(self, finger: str, t: float, normal_n: float, tangential_n: float,
                   now: float | None = None) -> list[ReflexEvent]:
        """One frame of a finger: its normal and tangential force (newtons)."""
        if not (math.isfinite(normal_n) and math.isfinite(tangential_n)):
            raise ValueError("force is not finite")
        if normal_n < self.cfg.min_normal_n:
            self._ratio.pop(finger, None)
            return []
        raw = abs(tangential_n) / normal_n
        prev = self._ratio.get(finger, raw)
        r = prev + self.cfg.smooth * (raw - prev)
        r0 = self._ratio0.setdefault(finger, r)
        self._ratio[finger] = r
        now = t if now is None else now
        if r - r0 > self.cfg.ratio_rise or raw - prev > self.cfg.ratio_step:
            out = self._emit(t, now, "force", raw)
            self._ratio0[finger] = r       # a new reference: raise again only if it grows
            return out
        # The grip rose (the ratio fell): the reference follows it down.
        self._ratio0[finger] = min(r0, r)
        return []
