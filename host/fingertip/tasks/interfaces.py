"""What a recipe needs from a robot: implement :class:`RobotHand` and :class:`RobotArm`.

Both are small on purpose. Positions are in millimetres, speeds in mm/s, times in seconds.
Forces are never computed by the robot: each finger hands over its fingertip's raw
:class:`~fingertip.device.Frame` and the force model of that fingertip, and the recipe does
the rest (filtering, thresholds, aborts). See ``docs/tasks.md`` for a skeleton.
"""
from __future__ import annotations

import abc
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..device import Frame

FrameSet = Mapping[str, Frame]
"""One frame per finger, read together (finger name -> frame)."""


@dataclass
class AudioBlock:
    """Contact-microphone samples of one fingertip, with their times.

    ``t0`` is the time of ``samples[0]`` on the clock of the frames' ``host_time`` and of
    :meth:`RobotArm.z_history`, so that vibration onsets can be matched with the arm's height.
    """

    samples: np.ndarray
    """float32, 1.0 = the sound card's full scale."""
    fs: float
    t0: float

    @property
    def t_end(self) -> float:
        """The time just after the last sample (where the next block starts)."""
        return self.t0 + len(self.samples) / self.fs

    def times(self) -> np.ndarray:
        return self.t0 + np.arange(len(self.samples)) / self.fs


class ForceEstimator(Protocol):
    """What a finger's force model must offer (a
    :class:`~fingertip.models.force.runtime.ForceModel` does)."""

    def estimate_frame(self, frame: Frame, channels: tuple[int, ...] | None = None, *,
                       strict: bool = False): ...


class ContactSource(Protocol):
    """Per-finger contact detection fed by a recipe (an
    :class:`~fingertip.events.contact_set.ContactSet` is one): force frames always, piezo
    blocks when ``needs_audio``. Each feed returns (finger, event) pairs; an event has
    ``kind`` ("contact", "contact_confirmed", ...), ``time`` and ``detected_at``."""

    @property
    def needs_audio(self) -> bool: ...

    def feed_force(self, finger: str, t: float, force_n: float,
                   now: float | None = None) -> list: ...

    def feed_audio(self, finger: str, samples: np.ndarray, t0: float,
                   now: float | None = None) -> list: ...

    def motion(self, t: float, fingers=None) -> None: ...


class RobotHand(abc.ABC):
    """A hand whose fingers close and open along one axis each, with a fingertip on each.

    ``step`` must return quickly (it queues or starts a motion; it does not wait for it to
    finish): recipes call it once per sensor frame.
    """

    @property
    @abc.abstractmethod
    def fingers(self) -> list[str]:
        """The finger names, in a fixed order."""

    @abc.abstractmethod
    def step(self, increments_mm: Mapping[str, float]) -> None:
        """Move each named finger by its increment: > 0 closes, < 0 opens. Fingers not named
        do not move. Implementations clamp at their travel limits."""

    @abc.abstractmethod
    def positions(self) -> dict[str, float]:
        """Each finger's closing travel in mm (0: fully open)."""

    @abc.abstractmethod
    def read(self, timeout: float = 0.5) -> FrameSet | None:
        """The next frame of every finger's fingertip (one set per sensor period), or None
        when no complete set arrived within ``timeout`` seconds."""

    @abc.abstractmethod
    def force_model(self, finger: str) -> ForceEstimator:
        """The calibrated force model of this finger's fingertip."""

    def read_audio(self, finger: str) -> AudioBlock:
        """The piezo samples of ``finger``'s fingertip captured since the previous call (the
        first call starts the capture and may return an empty block). Needed by the cup and
        shake recipes, not by the pinch."""
        raise NotImplementedError(f"{type(self).__name__} has no audio capture")

    def move(self, speeds_mm_s: Mapping[str, float]) -> None:
        """Start moving each named finger at a constant speed (> 0 closes, 0 stops) until
        told otherwise; returns at once. Needed by a pinch that approaches at a set speed
        (``PinchConfig.approach_speed_mm_s``)."""
        raise NotImplementedError(f"{type(self).__name__} has no speed-controlled moves")

    def step_z(self, increments_mm: Mapping[str, float]) -> None:
        """Move each named fingertip vertically (along the hand's axis, > 0 up) relative to
        the others; returns at once. Needed only to separate stacked cups."""
        raise NotImplementedError(f"{type(self).__name__} cannot move fingers vertically")

    def open_fully(self) -> None:
        """Open every finger to its start (the safe state after an abort)."""
        pos = self.positions()
        self.step({f: -p for f, p in pos.items() if p > 0})


class RobotArm(abc.ABC):
    """An arm carrying the hand: Cartesian moves, a vertical slide, a horizontal shake.

    ``slide_z`` and ``shake`` start a motion and return; :meth:`moving` says when it is over,
    so a recipe can keep reading fingertip frames during the motion.
    """

    @abc.abstractmethod
    def move_to(self, x_mm: float, y_mm: float, z_mm: float) -> None:
        """Move the hand (tool point) to a Cartesian position; blocks until there."""

    @abc.abstractmethod
    def position(self) -> tuple[float, float, float]:
        """The tool point now (x, y, z) in mm."""

    @abc.abstractmethod
    def slide_z(self, dz_mm: float, speed_mm_s: float) -> None:
        """Start a vertical move by ``dz_mm`` (> 0 up) at a constant speed; returns at once."""

    @abc.abstractmethod
    def shake(self, amplitude_mm: float, frequency_hz: float, duration_s: float) -> None:
        """Start a horizontal sinusoidal shake x(t) = ``amplitude_mm`` sin(2 pi f t) about
        the current position (the paper's 5 cm at 0.67 Hz for 5.6 s); returns at once."""

    @abc.abstractmethod
    def moving(self) -> bool:
        """True while a slide or shake started here is still running."""

    @abc.abstractmethod
    def stop(self) -> None:
        """Stop any motion now (the safe state after an abort)."""

    def z_history(self, since: float) -> tuple[np.ndarray, np.ndarray]:
        """The arm's logged heights from time ``since`` on: (times, z in mm), times
        increasing, on the clock of the frames and the audio (the paper synchronises the
        rims' vibration onsets with the robot's Z). Needed by the cup recipe."""
        raise NotImplementedError(f"{type(self).__name__} keeps no z(t) log")


def require(recipe: str, hand: RobotHand, arm: RobotArm | None, *,
            hand_methods: tuple[str, ...] = (), arm_methods: tuple[str, ...] = ()) -> None:
    """Refuse to start ``recipe`` before anything moves when the robot lacks one of the
    optional capabilities it needs (a method still the base class's): the error names them
    all, instead of surfacing mid-task with an object in the fingers."""
    missing = [f"{type(hand).__name__}.{m}" for m in hand_methods
               if getattr(type(hand), m) is getattr(RobotHand, m)]
    missing += [f"{type(arm).__name__}.{m}" for m in arm_methods
                if arm is None or getattr(type(arm), m) is getattr(RobotArm, m)]
    if missing:
        raise NotImplementedError(f"{recipe} needs {', '.join(missing)}: implement "
                                  f"{'it' if len(missing) == 1 else 'them'} for this robot "
                                  "(docs/tasks.md has a skeleton)")
