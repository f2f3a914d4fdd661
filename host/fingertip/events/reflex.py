"""Contact reflexes on live streams: the piezo hears a touch in a millisecond, the force
confirms it.

Three streaming detectors, fed block by block as data arrives (arrays in, events out, no
threads), each event carrying both when it happened and when it was known:

- :class:`OnsetDetector`: impulsive onsets in the piezo signal, in a 200-3000 Hz band
  (above mains hum, below most of the motors' gearbox noise). Short-term energy (0.5 ms)
  against a long-term level (following rising noise within 10 ms and falling noise within
  50 ms, frozen during an event) triggers at ``k_on`` times the level: steady or slowly
  changing noise, however loud (a motor at full speed), raises the level and not the
  ratio; a touch is a jump of the ratio. The hand gates it while its motors start a move
  (:meth:`FusedContact.motion`), as robot audition gates ego-noise.
- :class:`ForceContact`: make and break from the calibrated force magnitude (newtons), with
  a zero that follows slow drift out of contact and hysteresis (the same rules as
  :func:`.detect.contact_intervals`, online).
- :class:`FusedContact`: a piezo onset while free gives ``contact`` at once (``source`` =
  "piezo"); a force make within ``window_s`` turns it into ``contact_confirmed``, none
  into ``contact_retracted``. A force make without an onset (a touch too soft to hear)
  still gives ``contact`` (``source`` = "force"). Release works the same way
  (``release``, ``release_confirmed``, ``release_retracted``). Every event goes to the
  registered callbacks in order; :class:`RecorderSink` writes them to a recording's events
  topic (``/fingertip/<name>/events``).

Times are on the host clock of the frames' ``host_time`` and the audio's ``t0``. ``now``
arguments say when the data became available (the end of the audio block, a frame's
arrival); by default the end of the data itself, which is what simulations use.
"""
from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy import signal


@dataclass(frozen=True, slots=True)
class ReflexEvent:
    """``kind`` at ``time`` (the detector's estimate of when it happened), known at
    ``detected_at``; ``source`` is "piezo" or "force"; ``value`` a magnitude (newtons for
    force events, onset energy ratio for piezo ones)."""

    kind: str
    time: float
    detected_at: float
    source: str
    value: float = 0.0

    @property
    def latency_s(self) -> float:
        """From the estimated event time to the moment it was known."""
        return self.detected_at - self.time

    @property
    def detail(self) -> str:
        return json.dumps({"source": self.source, "latency_ms": round(self.latency_s * 1e3, 3),
                           "detected_at": self.detected_at})


Callback = Callable[[ReflexEvent], None]


class RecorderSink:
    """A callback writing events to a recorder's events topic (anything with
    ``write_event(name, kind, value, host_time=, detail=)``, e.g.
    :class:`fingertip.record.Recorder`)."""

    def __init__(self, recorder, name: str) -> None:
        self.recorder = recorder
        self.name = name
        self.written = 0
        self.refused = 0

    def __call__(self, ev: ReflexEvent) -> None:
        ok = self.recorder.write_event(self.name, ev.kind, ev.value, host_time=ev.time,
                                       detail=ev.detail)
        if ok is False:
            self.refused += 1
        else:
            self.written += 1


# --- piezo onsets -----------------------------------------------------------------------------

@dataclass
class OnsetConfig:
    band_hz: tuple[float, float] = (200.0, 3000.0)
    """Band-pass (2nd order) before the energy: see :class:`OnsetDetector`."""
    hop_s: float = 0.00025
    """Energy is computed over hops of this length; the short-term window is two hops."""
    rise_tau_s: float = 0.01
    """The long-term level follows rising noise with this time constant (a motor speeding
    up over tens of milliseconds), ..."""
    fall_tau_s: float = 0.05
    """... and falling noise with this one."""
    k_on: float = 8.0
    """Trigger when short-term energy exceeds k_on x the long-term level (+ floor)."""
    k_off: float = 3.0
    """An event ends when the short-term energy stays below k_off x level for ``quiet_s``."""
    quiet_s: float = 0.001
    max_event_s: float = 0.02
    """An event still loud after this is a new steady level (a motor started): the level
    jumps to it and detection resumes."""
    dead_s: float = 0.003
    """No new onset within this time of the previous one."""
    floor: float = 1e-10
    """Absolute energy floor (full-scale units squared): silence never triggers."""
    warmup_s: float = 0.01
    """The level is learnt over this time before anything triggers."""


class OnsetDetector:
    """Streaming impulsive-onset detector for one piezo (see the module text).

    A 200-3000 Hz band-pass removes mains hum below and most of the motors' broadband
    gearbox noise above, and keeps most of a touch's energy, on the nail (cap modes from
    2.3 kHz) and on the skin's side (a 3 ms pulse: below 1 kHz). On simulated touches with
    the hand's motor running it gave the highest ratio of touch to background energy (the
    worst of 100 touches: 39) of a raw signal (5), a first (2.3) or second (1.2) difference
    and 200 or 500 Hz high-passes (33, 15). Blocks of any size give the same onsets (the
    filter, the hops and the level carry over).
    """

    def __init__(self, fs: float, cfg: OnsetConfig | None = None) -> None:
        self.fs = float(fs)
        self.cfg = c = cfg or OnsetConfig()
        if fs <= 0:
            raise ValueError("fs must be > 0")
        lo, hi = c.band_hz
        if not 0 < lo < hi < fs / 2:
            raise ValueError("band_hz must satisfy 0 < low < high < fs / 2")
        self._sos = signal.butter(2, [lo, hi], "bandpass", fs=fs, output="sos")
        self._zi = np.zeros((self._sos.shape[0], 2))
        self.hop = max(1, int(round(c.hop_s * fs)))
        self._up = 1 - math.exp(-self.hop / (c.rise_tau_s * fs))
        self._down = 1 - math.exp(-self.hop / (c.fall_tau_s * fs))
        self._carry = np.zeros(0)    # filtered samples not yet making a whole hop
        self._index = 0              # absolute index of the next hop's first sample
        self._prev = 0.0             # energy of the previous hop
        self._level = 0.0
        self._warm = 0
        self._warm_hops = max(1, int(round(c.warmup_s * fs / self.hop)))
        self._quiet_hops = max(1, int(round(c.quiet_s * fs / self.hop)))
        self._max_hops = max(1, int(round(c.max_event_s * fs / self.hop)))
        self._active = 0             # hops since the current event began (0: none)
        self._quiet = 0
        self._last_onset = -math.inf
        self.t_origin: float | None = None
        self.onsets = 0
        self.relevels = 0
        """Events that lasted longer than ``max_event_s`` (the level jumped)."""
        self._gates: list[tuple[float, float]] = []
        self.gated = 0
        """Hops above threshold ignored inside a gate."""

    def gate(self, t_from: float, t_to: float) -> None:
        """Ignore onsets from ``t_from`` to ``t_to`` and let the level follow the signal
        at once: the hand tells the detector when its own motors start a move (their noise
        rises within tens of milliseconds, faster than the level follows), as robot
        audition gates ego-noise with the motor commands."""
        if t_to < t_from:
            raise ValueError("gate must end after it starts")
        self._gates.append((t_from, t_to))

    @property
    def level(self) -> float:
        """The long-term energy level (full-scale units squared)."""
        return self._level

    def feed(self, samples: np.ndarray, t0: float) -> list[tuple[float, float]]:
        """Samples from time ``t0`` (contiguous with the previous block) -> onsets as
        (time, ratio of short-term energy to level)."""
        x = np.asarray(samples, dtype=np.float64)
        if x.ndim > 1:
            x = x.mean(axis=1)
        if x.size == 0:
            return []
        if not np.isfinite(x).all():
            raise ValueError("audio contains NaN or infinite values")
        if self.t_origin is None:
            self.t_origin = t0 - self._index / self.fs
        y, self._zi = signal.sosfilt(self._sos, x, zi=self._zi)
        y = np.concatenate((self._carry, y))
        m = len(y) // self.hop
        self._carry = y[m * self.hop:]
        if m == 0:
            return []
        y = y[: m * self.hop]
        e = np.einsum("ij,ij->i", y.reshape(m, self.hop), y.reshape(m, self.hop)) / self.hop
        return self._scan(e.tolist())

    def _scan(self, e: list[float]) -> list[tuple[float, float]]:
        c = self.cfg
        out = []
        prev, level = self._prev, self._level
        thr_k, floor = c.k_on, c.floor
        for i, ei in enumerate(e):
            sta = 0.5 * (ei + prev)
            prev = ei
            if self._warm < self._warm_hops:
                self._warm += 1
                level += (sta - level) / self._warm
                continue
            if self._active:
                self._active += 1
                if sta < c.k_off * level + floor:
                    self._quiet += 1
                    if self._quiet >= self._quiet_hops:
                        self._active = 0
                else:
                    self._quiet = 0
                if self._active > self._max_hops:
                    self._active, level = 0, sta
                    self.relevels += 1
                continue
            thr = thr_k * level + floor
            if sta > thr:
                t = self.t_origin + (self._index + i * self.hop) / self.fs
                if self._gates and self._gated(t):
                    self.gated += 1
                    level = sta
                    continue
                if t - self._last_onset >= c.dead_s:
                    # The onset is the start of the first hop above threshold.
                    t_on = t if ei > thr else t - self.hop / self.fs
                    out.append((t_on, sta / max(level, 1e-30)))
                    self._last_onset = t_on
                    self._active, self._quiet = 1, 0
                    self.onsets += 1
                    continue
            level += (self._up if sta > level else self._down) * (sta - level)
        self._prev, self._level = prev, level
        self._index += len(e) * self.hop
        if self._gates:
            t_now = self.t_origin + self._index / self.fs
            self._gates = [g for g in self._gates if g[1] >= t_now]
        return out

    def _gated(self, t: float) -> bool:
        return any(a <= t <= b for a, b in self._gates)


# --- force make and break -----------------------------------------------------------------

@dataclass
class ForceConfig:
    make_n: float = 0.03
    """Make above this force over the zero. 30 mN: above the fingertip's inertial force
    while the hand accelerates (a few grams at a few m/s^2) and its noise."""
    break_n: float = 0.015
    release_fraction: float = 0.15
    track_s: float = 0.3
    settle_s: float = 0.2
    """After a break the zero is the signal itself for this long: the prism's creep and
    hysteresis leave a residue that unloads slowly."""


class ForceContact:
    """Online make/break on a force magnitude stream (newtons, tared)."""

    def __init__(self, cfg: ForceConfig | None = None) -> None:
        self.cfg = cfg or ForceConfig()
        self.inside = False
        self.zero: float | None = None
        self.peak = 0.0
        self._t: float | None = None
        self._settle_until = -math.inf

    def feed(self, t: float, force_n: float) -> str | None:
        """One frame; returns "make", "break" or None."""
        if not math.isfinite(force_n):
            raise ValueError("force is not finite")
        c = self.cfg
        if self.zero is None or (not self.inside and t < self._settle_until):
            self.zero = force_n
        m = force_n - self.zero
        out = None
        if not self.inside:
            if m > c.make_n:
                self.inside, self.peak, out = True, m, "make"
            elif self._t is not None:
                a = min(1.0, (t - self._t) / c.track_s)
                self.zero += a * (force_n - self.zero)
        else:
            self.peak = max(self.peak, m)
            if m < max(c.break_n, c.release_fraction * self.peak):
                self.inside, out = False, "break"
                self.zero = force_n
                self._settle_until = t + c.settle_s
        self._t = t
        return out


# --- fused ------------------------------------------------------------------------------------

@dataclass
class FusedConfig:
    window_s: float = 0.15
    """How long after a piezo onset the force may take to confirm it (covers a frame period
    at 15 Hz plus the rise of the force on a soft object)."""
    unloading_s: float = 0.5
    """After the force breaks contact (at a fraction of its peak) the first onset within
    this time, before the force is back near its zero, is the skin leaving the object."""
    onset: OnsetConfig = field(default_factory=OnsetConfig)
    force: ForceConfig = field(default_factory=ForceConfig)


class FusedContact:
    """Contact and release from a piezo and a force stream (see the module text)."""

    def __init__(self, fs: float, cfg: FusedConfig | None = None,
                 callbacks: list[Callback] | None = None) -> None:
        self.cfg = cfg or FusedConfig()
        self.onsets = OnsetDetector(fs, self.cfg.onset)
        self.force = ForceContact(self.cfg.force)
        self.callbacks: list[Callback] = list(callbacks or [])
        self.state = "free"          # free, pending, contact, releasing
        self._pending: ReflexEvent | None = None
        self._zero_before = 0.0
        self._unloading_until = -math.inf
        self.counts: dict[str, int] = {}

    def on(self, callback: Callback) -> None:
        self.callbacks.append(callback)

    def motion(self, t: float, guard_s: float = 0.08) -> None:
        """The hand starts (or speeds up) a move at ``t``: gate the piezo for ``guard_s``
        (its motor noise ramps up); the force still detects a contact meanwhile."""
        self.onsets.gate(t, t + guard_s)

    def _emit(self, kind: str, time: float, now: float, source: str, value: float
              ) -> ReflexEvent:
        ev = ReflexEvent(kind, time, now, source, value)
        self.counts[kind] = self.counts.get(kind, 0) + 1
        for cb in self.callbacks:
            cb(ev)
        return ev

    def _expire(self, now: float) -> list[ReflexEvent]:
        p = self._pending
        if p is None or now <= p.time + self.cfg.window_s:
            return []
        self._pending = None
        if self.state == "pending":
            self.state = "free"
            return [self._emit("contact_retracted", p.time, now, "force", 0.0)]
        self.state = "contact"
        return [self._emit("release_retracted", p.time, now, "force", 0.0)]

    def feed_audio(self, samples: np.ndarray, t0: float, now: float | None = None
                   ) -> list[ReflexEvent]:
        """A block of piezo samples from ``t0``, available at ``now`` (default: its end)."""
        now = t0 + len(samples) / self.onsets.fs if now is None else now
        return self.feed_onsets(self.onsets.feed(samples, t0), now)

    def feed_onsets(self, onsets: list[tuple[float, float]], now: float
                    ) -> list[ReflexEvent]:
        """Onsets (time, ratio) found by an :class:`OnsetDetector` run elsewhere (another
        thread, or a whole recording at once), known at ``now``."""
        out = []
        for t, ratio in onsets:
            out += self._expire(t)
            if self.state == "free" and t < self._unloading_until:
                # The force broke contact at a fraction of its peak; the skin leaves the
                # object a little later, with a click: that is this onset.
                self.counts["break_heard"] = self.counts.get("break_heard", 0) + 1
                self._unloading_until = -math.inf
            elif self.state in ("free", "pending"):
                if self.state == "pending":
                    # A newer onset before the force confirmed: the latest is the candidate.
                    out.append(self._emit("contact_retracted", self._pending.time, now,
                                          "piezo", 0.0))
                self.state = "pending"
                self._pending = self._emit("contact", t, now, "piezo", ratio)
                out.append(self._pending)
            elif self.state == "contact":
                self.state = "releasing"
                self._pending = self._emit("release", t, now, "piezo", ratio)
                out.append(self._pending)
        return out

    def feed_force(self, t: float, force_n: float, now: float | None = None
                   ) -> list[ReflexEvent]:
        """One force frame (tared magnitude, newtons) of time ``t``, available at ``now``."""
        now = t if now is None else now
        zero = self.force.zero
        change = self.force.feed(t, force_n)
        m = force_n - (self.force.zero or 0.0)
        fc = self.cfg.force
        if self._unloading_until > t and force_n - self._zero_before < 2 * fc.break_n:
            self._unloading_until = -math.inf
        out = []
        if change == "make":
            self._zero_before = force_n if zero is None else zero
            if self.state == "pending":
                out.append(self._emit("contact_confirmed", self._pending.time, now, "force", m))
                self._pending = None
            else:
                out.append(self._emit("contact", t, now, "force", m))
            self.state = "contact"
        elif change == "break":
            if self.state == "releasing":
                out.append(self._emit("release_confirmed", self._pending.time, now, "force",
                                      m))
                self._pending = None
            elif self.state in ("contact", "pending"):
                out.append(self._emit("release", t, now, "force", m))
                self._pending = None
                self._unloading_until = t + self.cfg.unloading_s
            self.state = "free"
        out += self._expire(t)
        return out


class ForceOnlyContact:
    """The baseline: contact and release from the force stream alone."""

    def __init__(self, cfg: ForceConfig | None = None,
                 callbacks: list[Callback] | None = None) -> None:
        self.force = ForceContact(cfg)
        self.callbacks: list[Callback] = list(callbacks or [])

    def feed_force(self, t: float, force_n: float, now: float | None = None
                   ) -> list[ReflexEvent]:
        change = self.force.feed(t, force_n)
        if change is None:
            return []
        ev = ReflexEvent("contact" if change == "make" else "release", t,
                         t if now is None else now, "force", force_n)
        for cb in self.callbacks:
            cb(ev)
        return [ev]
