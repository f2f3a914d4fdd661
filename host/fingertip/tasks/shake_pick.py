"""Shake-and-pick (the paper's Fig. 7): find which of two identical boxes holds the requested
material by shaking each, then open that one.

For each box: move over it, grip it with two opposite fingers (the shared
:class:`~.grip.Grip`, which also keeps the nails pressed on its sides), lift, shake
horizontally (0.67 Hz, 50 mm, 5.6 s) while the shake classifier runs at 10 Hz on the
latest 86-frame window (1.0 s) of the gripping finger's contact microphone, then put the
box back: lowered at the lift's speed, held still a moment, released, and left only once the
fingers are open. A box can turn in a two-finger grip (its contents shifting to one end) and
land a few mm from where it stood; a hand whose pusher stands close to the box's end steps
aside from a box before rising off it and comes down beside one before moving in
(``clear_mm``), so that the pusher's nail neither lands on a moved box's roof nor lifts it
from inside the sleeve.

The box's label is the majority vote of its predictions. The box voted for the target is
opened (gripped on its sides while a third finger pushes the tray out); when both
or neither box got the target's vote, the one with the higher mean probability of the target
is opened.

Only :class:`RobotHand` / :class:`RobotArm`, the sensor streams and the classifier are used.
"""
from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..models.vibration.classify import Prediction, VibrationClassifier, majority_vote
from ..models.vibration.features import as_recording
from .grip import Grip, PinchConfig, PinchOutcome, PinchResult, SensorFault, force_vectors
from .interfaces import RobotArm, RobotHand, require
from .touch import Touch

log = logging.getLogger(__name__)


def _box_grip() -> PinchConfig:
    return PinchConfig(1.2, step_mm=0.03, lift_mm=30.0, lift_speed_mm_s=30.0, timeout_s=30.0)


@dataclass
class ShakeConfig:
    amplitude_mm: float = 50.0
    frequency_hz: float = 0.67
    duration_s: float = 5.6
    grip: PinchConfig = field(default_factory=_box_grip)
    fingers: tuple[str, str] = ("f0", "f2")
    """The two opposite fingers that grip a box by its sides."""
    listen: str = "f0"
    """Whose contact microphone feeds the classifier."""
    pusher: str = "f1"
    """The finger that pushes a box's tray out."""
    push_mm: float = 8.0
    """How far the pusher goes on once it touches the tray's end."""
    touch_n: float = 0.1
    """The pusher's force that says it touches (the tray slides at 0.3 N)."""
    reach_mm: float = 20.0
    """Opening fails when the pusher touches nothing within this travel."""
    open_dz_mm: float = 0.0
    """Opening, the box is gripped this much higher (< 0: lower) than where it is read: the
    pusher's fingertip, leaning over its nail, meets the sleeve's roof as the tray's end goes
    in, later the lower the nail pushes."""
    push_step_mm: float = 0.25
    step_s: float = 0.1
    """One prediction every ``step_s`` (10 Hz)."""
    clear_mm: tuple[float, float] = (0.0, 0.0)
    """The arm's step (x, y) away from a box along the pusher's axis, outwards: it comes down
    onto a box this far aside and moves in, and steps aside before it rises off one it put
    back. A box that swung in the grip lands a few mm from where it stood; the pusher, which
    stands close to the box's end, would come down on its roof or, with the tray jolted in,
    rise under the roof from inside the sleeve and lift it. (0, 0): straight down and up."""
    settle_s: float = 0.3
    """Putting a box back: held still this long once the arm is down, and the fingers given
    this long to open before the arm moves on (a box tilted in the grip lands on one edge,
    and nails still closing drag it along)."""


class LiveShakeClassifier:
    """Feeds audio blocks as they arrive and predicts on the latest window every ``step_s``."""

    def __init__(self, clf: VibrationClassifier, step_s: float) -> None:
        self.clf = clf
        self.step_s = step_s
        self.span_s = clf.pipeline.span_s()
        self.predictions: list[Prediction] = []
        self._buf = np.zeros(0, np.float32)
        self._t0: float | None = None
        self._next: float | None = None

    def feed(self, samples: np.ndarray, fs: float, t0: float) -> None:
        if self._t0 is None:
            self._t0 = t0
        self._buf = np.concatenate([self._buf, samples]) if len(self._buf) else samples
        n = int(math.ceil(self.span_s * fs)) + 2
        t_end = self._t0 + len(self._buf) / fs
        if self._next is None:
            self._next = self._t0 + n / fs
        while t_end >= self._next:
            stop = int(round((self._next - self._t0) * fs))
            seg = self._buf[max(0, stop - n):stop]
            w = self.clf.pipeline.windows(as_recording(seg, fs, "live audio", full_scale=1.0))
            if len(w):
                p = self.clf._predictions(w, self.clf.predict(w.inputs[-1:]),
                                          self._next - self._t0 - len(seg) / fs)[-1]
                self.predictions.append(p)
            self._next += self.step_s
        keep = int(n + self.step_s * fs)              # what the next windows still need
        if len(self._buf) > 4 * keep:
            cut = len(self._buf) - keep
            self._buf = self._buf[cut:]
            self._t0 += cut / fs

    def probabilities(self) -> np.ndarray:
        return np.array([[p.probabilities[c] for c in self.clf.classes]
                         for p in self.predictions]).reshape(-1, len(self.clf.classes))


@dataclass
class BoxReading:
    x_mm: float
    vote: str | None = None
    predictions: int = 0
    shares: dict[str, float] = field(default_factory=dict)
    mean_probabilities: dict[str, float] = field(default_factory=dict)
    grip: PinchResult | None = None
    failure: str | None = None
    """None, "grasp failure" (the grip aborted) or "no predictions"."""


@dataclass
class ShakePickResult:
    target: str
    readings: list[BoxReading]
    chosen: int | None = None
    failure: str | None = None
    """None, or "grasp failure" / "no predictions" (reading a box), "open failure"."""


def read_box(hand: RobotHand, arm: RobotArm, clf: VibrationClassifier,
             xyz: tuple[float, float, float], cfg: ShakeConfig) -> BoxReading:
    """Grip, lift and shake the box at ``xyz``; classify its content; put it back."""
    require("reading a box", hand, arm, hand_methods=("read_audio",))
    out = BoxReading(xyz[0])
    come_down(arm, xyz, cfg)
    grip = Grip(hand, cfg.grip, fingers=cfg.fingers, arm=arm)
    out.grip = grip.result
    live = LiveShakeClassifier(clf, cfg.step_s)
    if not grip.close():
        out.failure = "grasp failure"
        return out
    arm.slide_z(cfg.grip.lift_mm, cfg.grip.lift_speed_mm_s)
    if not grip.hold(arm.moving):
        out.failure = "grasp failure"
        return out
    hand.read_audio(cfg.listen)                        # start (or flush) the capture
    arm.shake(cfg.amplitude_mm, cfg.frequency_hz, cfg.duration_s)
    last = [grip.now]

    def listen(now: float) -> None:
        if now - last[0] >= cfg.step_s or not arm.moving():
            last[0] = now
            b = hand.read_audio(cfg.listen)
            if len(b.samples):
                live.feed(b.samples, b.fs, b.t0)

    ok = grip.hold(arm.moving, listen) and put_back(hand, arm, grip, xyz, cfg)
    if not ok:
        out.failure = "grasp failure"
        return out
    p = live.probabilities()
    out.predictions = len(p)
    if not len(p):
        out.failure = "no predictions"
        return out
    out.vote = clf.classes[majority_vote(p)]
    out.shares = {c: float(np.mean(p.argmax(axis=1) == i)) for i, c in enumerate(clf.classes)}
    out.mean_probabilities = {c: float(p[:, i].mean()) for i, c in enumerate(clf.classes)}
    return out


def put_back(hand: RobotHand, arm: RobotArm, grip: Grip, xyz: tuple[float, float, float],
             cfg: ShakeConfig) -> bool:
    """Lower the held box at the lift's speed to where it was gripped (``xyz``), hold it
    still ``settle_s``, open the fingers, wait ``settle_s`` for them and step ``clear_mm``
    aside; False after an abort (the grip's: the fingers are open)."""
    arm.slide_z(-cfg.grip.lift_mm, cfg.grip.lift_speed_mm_s)
    if not grip.hold(arm.moving):
        return False
    end = grip.now + cfg.settle_s
    if not grip.hold(lambda: grip.now < end):
        return False
    hand.open_fully()
    end = grip.now + cfg.settle_s
    while (frames := hand.read(cfg.grip.read_timeout_s)) is not None:
        if max(f.host_time for f in frames.values()) >= end:
            break
    if any(cfg.clear_mm):
        arm.move_to(*aside(xyz, cfg))
    return True


def aside(xyz: tuple[float, float, float], cfg: ShakeConfig) -> tuple[float, float, float]:
    """The grip position ``xyz`` stepped ``clear_mm`` aside."""
    return (xyz[0] + cfg.clear_mm[0], xyz[1] + cfg.clear_mm[1], xyz[2])


def come_down(arm: RobotArm, xyz: tuple[float, float, float], cfg: ShakeConfig) -> None:
    """Move to the grip position ``xyz``, coming down ``clear_mm`` aside and moving in."""
    if any(cfg.clear_mm):
        arm.move_to(*aside(xyz, cfg))
    arm.move_to(*xyz)


def open_box(hand: RobotHand, arm: RobotArm, xyz: tuple[float, float, float],
             cfg: ShakeConfig) -> bool:
    """Grip the box's sides (``open_dz_mm`` above ``xyz``), close the pusher until it
    touches the tray's end (a box put back may have moved: the end is found, not assumed)
    and push the tray ``push_mm`` past the touch; False after an abort or no touch within
    ``reach_mm``."""
    come_down(arm, (xyz[0], xyz[1], xyz[2] + cfg.open_dz_mm), cfg)
    rest = []
    while len(rest) < cfg.grip.baseline_frames:         # the pusher free, as the grip zeroes
        frames = hand.read(cfg.grip.read_timeout_s)
        if frames is None:
            return False
        try:
            rest.append(force_vectors(hand, frames, [cfg.pusher])[cfg.pusher])
        except SensorFault as e:
            log.warning("opening: %s", e)
            return False
    touch = Touch(rest, cfg.touch_n, cfg.grip.window)
    grip = Grip(hand, cfg.grip, fingers=cfg.fingers, arm=arm)
    if not grip.close():
        return False
    pushed, touched_at, fault = [0.0], [math.inf], [False]

    def push(_now: float) -> None:
        if not touch.touched:
            try:
                f = force_vectors(hand, grip.frames, [cfg.pusher])[cfg.pusher]
            except SensorFault as e:
                fault[0] = not grip.abort(PinchOutcome.SENSOR_FAULT, str(e))
                return
            if touch.feed(f):
                touched_at[0] = pushed[0]
        hand.step({cfg.pusher: cfg.push_step_mm})
        pushed[0] += cfg.push_step_mm

    def pushing() -> bool:
        if fault[0]:
            return False
        return (pushed[0] - touched_at[0] < cfg.push_mm if touch.touched
                else pushed[0] < cfg.reach_mm)

    ok = grip.hold(pushing, push) and not fault[0] and touch.touched
    if not touch.touched:
        log.info("the pusher touched nothing within %.1f mm", cfg.reach_mm)
    hand.open_fully()
    return ok


def shake_and_pick(hand: RobotHand, arm: RobotArm, clf: VibrationClassifier,
                   boxes: Sequence[tuple[float, float, float]], target: str,
                   cfg: ShakeConfig | None = None) -> ShakePickResult:
    """Shake every box in ``boxes`` (grip positions), then open the one holding ``target``."""
    cfg = cfg or ShakeConfig()
    if target not in clf.classes:
        raise ValueError(f"target must be one of {clf.classes}, not {target!r}")
    res = ShakePickResult(target, [])
    for xyz in boxes:
        r = read_box(hand, arm, clf, xyz, cfg)
        res.readings.append(r)
        if r.failure:
            res.failure = r.failure
            return res
    hits = [i for i, r in enumerate(res.readings) if r.vote == target]
    if len(hits) == 1:
        res.chosen = hits[0]
    else:
        res.chosen = int(np.argmax([r.mean_probabilities[target] for r in res.readings]))
        log.info("%s boxes voted %s: opening the likelier one", len(hits) or "no", target)
    if not open_box(hand, arm, boxes[res.chosen], cfg):
        res.failure = "open failure"
    return res
