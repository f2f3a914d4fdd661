"""The simulated delta hand with speed-controlled fingers, force frames at a chosen rate and
each fingertip's piezo: what a pinch that approaches at speed needs
(:meth:`~fingertip.tasks.interfaces.RobotHand.move`, ``read``, ``read_audio``).

It is :class:`~fingertip.sim.world.hand.SimHand` (same world, same virtual strain units
and force models, same crushing: an object breaks the moment a finger's true force exceeds
its ``crush_n``) with three additions:

- Fingers move at a commanded speed: a command reaches the finger's motor ``COMMAND_S``
  after it is sent and the finger then accelerates or brakes at ``ACCEL_MM_S2`` (both
  assumed: a serial command to a small geared finger that stops from 80 mm/s within
  16 ms). Positions, forces and crushing are integrated in ``SUBSTEP_S`` steps while any
  finger moves, so an overshoot between two frames is seen by the object.
- Force frames come at ``rate_hz`` (15: the paper's controller; 80: the HX711's fastest):
  :meth:`read` waits at most ``timeout`` of simulated time for the next one and returns
  None when it is not due yet, as a real hand's read would.
- Each finger's piezo hears its own motor while the finger moves (joint speed = tip speed /
  ``LINK_MM``), speech at 65 dB SPL half of the time and room noise at 50 dB, and the
  make transient when it touches (4 mN per mm/s of approach, 0.4 x and a 3 ms pulse on the
  skin's side, log-normal scatter 15 %: as :mod:`.physics.touch`), through the audio chain
  (piezo, preamp, hum, sound card). :meth:`read_audio` gives the samples up to
  ``AUDIO_PATH_S`` before the present (the USB audio path; assumed).

The audio of a move is rendered once when the move starts (its speed profile up to a
horizon) and corrected, by linearity, when the finger touches or is told to stop: both
happen at or after the last sample already read, so nothing heard is ever rewritten.
"""
from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from ...tasks.interfaces import AudioBlock, FrameSet
from .hand import FINGERS, SimHand, SimWorld
from ..physics import AudioChain, Excitation
from ..physics.disturbances import MOTOR, motor_noise, room_noise, speech
from ..physics.touch import LINK_MM, MAKE_N_PER_MM_S
from ..physics.vibration import half_sine, place, smooth_noise

COMMAND_S = 0.002
"""From the host's command to the finger's motor (a serial command; assumed)."""
ACCEL_MM_S2 = 5000.0
"""Acceleration and braking of a finger (assumed: 80 mm/s stops within 16 ms)."""
SUBSTEP_S = 0.00025
AUDIO_PATH_S = 0.001
"""Audio reaches the host this long after the sound is made (USB isochronous transfer and
driver; assumed, as in :mod:`.reflex_eval`)."""
SPEECH_DB = 65.0
ROOM_DB = 50.0
HORIZON_MARGIN_S = 0.4


class _Voice:
    """One finger's piezo: preamp-input volts rendered ahead, from absolute sample
    ``start`` on (zeros beyond)."""

    def __init__(self, start: int) -> None:
        self.start = start
        self.volts = np.zeros(0)
        self.motor = np.zeros(0)
        self.motor_speed = 0.0

    def add(self, chain: AudioChain, at: int, force: np.ndarray) -> None:
        """Add the piezo's response to a nail force starting at absolute sample ``at``."""
        i = at - self.start
        if i < 0 or i >= len(self.volts) or not force.any():
            return
        n = len(self.volts) - i
        self.volts[i:] += chain.filter([Excitation(force[:n])], n)


class ApproachHand(SimHand):
    """See the module text. ``rate_hz``: force frames per second; ``seed``: the audio's."""

    def __init__(self, world: SimWorld, unit_seeds: Mapping[str, int], rate_hz: float = 80.0,
                 seed: int = 0) -> None:
        if not rate_hz > 0:
            raise ValueError(f"frame rate must be > 0 Hz, not {rate_hz}")
        super().__init__(world, unit_seeds)
        self.rate_hz = float(rate_hz)
        self.period = 1.0 / self.rate_hz
        self._next_frame = world.t_s + self.period
        self.chain = AudioChain()
        self.fs = self.chain.fs
        self._vel = dict.fromkeys(FINGERS, 0.0)
        self._cmd = dict.fromkeys(FINGERS, 0.0)
        self._queue: list[tuple[float, str, float]] = []   # (effective time, finger, speed)
        self._rng = {f: np.random.default_rng(np.random.SeedSequence([seed, 0x9A5E, i]))
                     for i, f in enumerate(FINGERS)}
        self._voices: dict[str, _Voice] = {}
        self._cursor: dict[str, int] = {}
        self.contact_s: dict[str, float] = {}
        """Truth: when each finger first touched the object (world time)."""
        self.contact_speed: dict[str, float] = {}
        self.stop_s: dict[str, float] = {}
        """When each finger was first told to stop (world time)."""

    # --- motion ---------------------------------------------------------------------------

    def move(self, speeds_mm_s: Mapping[str, float]) -> None:
        t_eff = self.world.t_s + COMMAND_S
        for f, v in speeds_mm_s.items():
            if f not in FINGERS:
                raise ValueError(f"no finger {f!r}; fingers: {FINGERS}")
            v = float(v)
            if not math.isfinite(v):
                raise ValueError("finger speed must be finite")
            if v == 0.0 and f not in self.stop_s:
                self.stop_s[f] = self.world.t_s
            self._queue.append((t_eff, f, v))
            self._plan_audio(f, t_eff, v)

    def open_fully(self) -> None:
        self._queue.clear()
        self._vel = dict.fromkeys(FINGERS, 0.0)
        self._cmd = dict.fromkeys(FINGERS, 0.0)
        super().open_fully()

    def _moving(self) -> bool:
        return bool(self._queue) or any(self._vel.values()) or any(self._cmd.values())

    def _run(self, dt: float) -> None:
        """Advance the world by ``dt``: in substeps while a finger moves."""
        w = self.world
        end = w.t_s + dt
        while end - w.t_s > 1e-12:
            if not self._moving():
                w.advance(end - w.t_s)
                return
            while self._queue and self._queue[0][0] <= w.t_s + 1e-12:
                _, f, v = self._queue.pop(0)
                self._cmd[f] = v
            h = min(SUBSTEP_S, end - w.t_s)
            if self._queue and self._queue[0][0] - w.t_s < h:
                h = self._queue[0][0] - w.t_s       # a command takes effect mid-step
            for f in FINGERS:
                v0, c = self._vel[f], self._cmd[f]
                if v0 == c:
                    if v0 == 0.0:
                        continue
                    v1 = v0
                else:
                    v1 = v0 + max(-ACCEL_MM_S2 * h, min(ACCEL_MM_S2 * h, c - v0))
                    self._vel[f] = v1
                p0 = w.positions[f]
                p1 = min(max(p0 + 0.5 * (v0 + v1) * h, 0.0), w.max_travel_mm)
                w.positions[f] = p1
                gap = w.obj.gaps_mm[f]
                if p0 < gap <= p1 and f not in self.contact_s:
                    self._touch(f, w.t_s + h * (gap - p0) / (p1 - p0), v1)
            w.advance(h)

    def _touch(self, f: str, t: float, speed: float) -> None:
        """The finger meets the object's surface at ``t``: its piezo hears the make."""
        self.contact_s[f] = t
        self.contact_speed[f] = speed
        voice = self._voices.get(f)
        if voice is None:
            return
        nail = self.world.heights_mm.get(f, 2.0) < 1.0
        amp = MAKE_N_PER_MM_S * speed * (1.0 if nail else 0.4) \
            * math.exp(0.15 * self._rng[f].standard_normal())
        kern = half_sine(3e-4 if nail else 3e-3, self.fs)
        at = int(math.floor(t * self.fs))
        voice.add(self.chain, at, place(len(kern) + 1, np.array([t - at / self.fs]),
                                        np.array([amp]), kern, self.fs))

    # --- frames ---------------------------------------------------------------------------

    def read(self, timeout: float = 0.5) -> FrameSet | None:
        due = self._next_frame - self.world.t_s
        if due > timeout:
            self._run(max(timeout, 0.0))
            return None
        self._run(max(due, 0.0))
        self._next_frame += self.period
        return self.frame_set()

    # --- audio ----------------------------------------------------------------------------

    def _plan_audio(self, f: str, t_eff: float, v: float) -> None:
        """Render (or correct) ``f``'s piezo for a speed command taking effect at t_eff."""
        voice = self._voices.get(f)
        if voice is None:
            return
        fs = self.fs
        at = int(math.ceil(t_eff * fs))
        i = at - voice.start
        v0 = self._commanded_before(f)
        if v > 0 and v0 == 0.0:
            # A move from rest: its motor noise up to the time it would take to cross the
            # whole remaining gap, plus a margin (later samples: no motor).
            gap = max(self.world.obj.gaps_mm[f] - self.world.positions[f], 0.0)
            n = int((gap / v + HORIZON_MARGIN_S) * fs)
            need = i + n + self.chain.pad
            if need > len(voice.volts):
                self._extend(f, voice, need)
            ramp = np.minimum(v, ACCEL_MM_S2 * (np.arange(n) + 1) / fs)
            m = motor_noise(n, fs, self._rng[f], ramp / LINK_MM, MOTOR)
            voice.motor = np.zeros(len(voice.volts))
            voice.motor[i:i + n] = m
            voice.motor_speed = v
            voice.add(self.chain, at, m)
        elif voice.motor_speed > 0 and 0 <= i < len(voice.motor):
            # A stop or a new speed: the motor's level follows the finger's speed as it
            # brakes (its pitch is kept: a few milliseconds).
            v_from = v0
            k = np.arange(len(voice.motor) - i) / fs
            speed = np.clip(v_from + np.sign(v - v_from) * ACCEL_MM_S2 * k, min(v, v_from),
                            max(v, v_from))
            scale = (speed / voice.motor_speed) ** MOTOR.exponent
            if v > voice.motor_speed:
                scale = np.minimum(scale, 1.0)   # faster than rendered: kept at its level
            delta = voice.motor[i:] * (scale - 1.0)
            voice.motor[i:] += delta
            voice.add(self.chain, at, delta)

    def _commanded_before(self, f: str) -> float:
        """``f``'s speed command before the one just queued."""
        for _, g, v in reversed(self._queue[:-1]):
            if g == f:
                return v
        return self._cmd[f]

    def _extend(self, f: str, voice: _Voice, need: int) -> None:
        """Grow ``f``'s rendered piezo to ``need`` samples with its background (speech half
        of the time, room noise)."""
        old = len(voice.volts)
        n = need - old
        rng = self._rng[f]
        talk = smooth_noise(n, self.fs, 0.3, rng) > 0
        bg = speech(n, self.fs, rng, SPEECH_DB) * talk + room_noise(n, self.fs, rng, ROOM_DB)
        voice.volts = np.concatenate([voice.volts, np.zeros(n)])
        voice.motor = np.concatenate([voice.motor, np.zeros(n)])
        voice.add(self.chain, voice.start + old, bg)

    def read_audio(self, finger: str) -> AudioBlock:
        if finger not in FINGERS:
            raise ValueError(f"no finger {finger!r}; fingers: {FINGERS}")
        end = int(math.floor((self.world.t_s - AUDIO_PATH_S) * self.fs))
        if finger not in self._voices:
            # The capture starts now; a second of background is rendered ahead.
            self._voices[finger] = voice = _Voice(end)
            self._extend(finger, voice, int(self.fs))
            self._cursor[finger] = end
        voice = self._voices[finger]
        a = self._cursor[finger]
        b = max(a, end)
        self._cursor[finger] = b
        if b - voice.start + self.chain.pad > len(voice.volts):
            self._extend(finger, voice, b - voice.start + int(self.fs))
        v = voice.volts[a - voice.start:b - voice.start].copy()
        out = self.chain.finish(v, a, self._rng[finger]).samples
        return AudioBlock(out, float(self.fs), a / self.fs)
