"""Two visually identical boxes in the simulated world, one with screws, one with rubber bands.

The boxes stand at x = -80 mm and x = +80 mm. The fingers close on whichever box the arm is
over (within 15 mm; else on air). While a box is lifted and gripped, :meth:`SimArm.shake`
makes its contents sound: a :class:`~fingertip.sim.physics.BoxShake` scene with the shake's
frequency, duration and the arm's real amplitude, the box's own fill, and the grip the fingers
really apply, heard by every finger pressing on the box. The recipe never sees the contents;
:attr:`BoxWorld.opened` records which box it opened.

Rules: a box is carried while friction x total grip >= its weight (0.1 kg + 5 g per item);
a box is **opened** when, while two opposite fingers (f0, f2) grip it with >= 0.3 N each,
the third finger (f1) pushes its tray ``tray_mm`` (6 mm) past the tray's end; the tray
slides with a constant 0.3 N of friction.

Per trial (seeded): which box holds what, the number of items (screws 5-12, rubber bands
6-14; the classifier's training shakes had 8 and 10), the arm's real shake amplitude
(0.8-1.05 x the command), the microphone's gain (x0.6-1.5) and mains (50/60 Hz).
"""
from __future__ import annotations

import logging
import os
import shutil
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..dataset import TASK_AMPLITUDE_GAIN, TASK_BOX_ITEMS, TASK_MAINS_HZ, TASK_PREAMP_GAIN
from ..physics import BoxShake, load
from .hand import (
    FINGERS,
    ObjectSpec,
    SimArm,
    SimHand,
    SimObject,
    SimWorld,
)
from .cache import cached

log = logging.getLogger(__name__)

MATERIALS = ("screws", "rubber_bands")
BOX_X_MM = (-80.0, 80.0)
SIDES = ("f0", "f2")
PUSHER = "f1"
NO_CONTACT_MM = 100.0
TRAY_FRICTION_N = 0.3
SHAKE_MODEL_SEED = 2024
"""Seed of the simulated training shakes (never used by a trial: trials draw their scenes'
seeds from their own seed sequence)."""


def box_spec(items: int) -> ObjectSpec:
    return ObjectSpec("box", stiffness_n_per_mm=1.5, crush_n=6.0, mass_kg=0.1 + 0.005 * items,
                      friction=0.6)


@dataclass
class Box:
    content: str
    items: int
    x_mm: float
    gaps_mm: dict[str, float]
    tray_mm: float = 0.0


@dataclass
class BoxWorld(SimWorld):
    boxes: list[Box] = field(default_factory=list)
    amplitude_gain: float = 1.0
    scene_seed: int = 0
    tray_open_mm: float = 6.0
    held: int | None = None
    """The box between the fingers (index), from when they start closing until they open."""
    opened: int | None = None
    shakes: list[dict] = field(default_factory=list)

    def _box_under_arm(self) -> int | None:
        x = self.arm_xy_mm[0]
        near = [i for i, b in enumerate(self.boxes) if abs(b.x_mm - x) < 15.0]
        return near[0] if near else None

    def advance(self, dt: float) -> None:
        closed = any(p > 0 for p in self.positions.values())
        if self.held is None and closed:
            self.held = self._box_under_arm()
            if self.held is None:
                self.obj = SimObject(box_spec(0), dict.fromkeys(FINGERS, NO_CONTACT_MM))
            else:
                b = self.boxes[self.held]
                self.obj = SimObject(box_spec(b.items), dict(b.gaps_mm))
        elif not closed and self.held is not None:
            self.held = None                      # released: the box stays where it is
            self.obj.lifted_mm = 0.0
        super().advance(dt)
        self._tray()

    def contact_forces(self) -> dict[str, float]:
        f = super().contact_forces()
        if PUSHER in f and self.held is not None:
            f[PUSHER] = min(f[PUSHER], TRAY_FRICTION_N)   # the tray slides
        return f

    def _tray(self) -> None:
        if self.held is None:
            return
        b = self.boxes[self.held]
        forces = self.contact_forces()
        if all(forces[s] >= 0.3 for s in SIDES):
            b.tray_mm = max(b.tray_mm, self.positions[PUSHER] - b.gaps_mm[PUSHER])
            if b.tray_mm >= self.tray_open_mm and self.opened is None:
                self.opened = self.held

    def start_shake(self, amplitude_mm: float, frequency_hz: float, duration_s: float) -> None:
        amp = amplitude_mm * self.amplitude_gain
        super().start_shake(amp, frequency_hz, duration_s)
        if self.held is None or self.obj.lifted_mm <= 0:
            return
        b = self.boxes[self.held]
        forces = self.contact_forces()
        pressing = tuple(f for f in SIDES if forces[f] > 0)
        if not pressing:
            return
        grip = float(np.mean([forces[f] for f in pressing]))
        scene = BoxShake(b.content, frequency_hz=frequency_hz, amplitude_m=amp / 1000,
                         duration=duration_s, grip_n=max(grip, 0.1), items=b.items,
                         seed=self.scene_seed + 7919 * len(self.shakes))
        self.audio.add(scene, self.t_s, duration_s, pressing)
        self.shakes.append({"box": self.held, "content": b.content, "grip_n": grip,
                            "amplitude_mm": amp})


def make_box_world(seed: int, *, hand_seed: int = 100) -> tuple[BoxWorld, SimHand, SimArm]:
    """One shake-and-pick trial (see the module's docstring for what varies)."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0xB0C5]))
    order = list(MATERIALS) if rng.uniform() < 0.5 else list(reversed(MATERIALS))
    boxes = []
    for content, x in zip(order, BOX_X_MM, strict=True):
        lo, hi = TASK_BOX_ITEMS[content]
        items = int(rng.integers(lo, hi + 1))
        boxes.append(Box(content, items, x, {f: float(rng.uniform(0.3, 1.3)) for f in FINGERS}))
    chain = {"preamp_gain": load().preamp.gain * float(rng.uniform(*TASK_PREAMP_GAIN)),
             "mains_hz": float(rng.choice(list(TASK_MAINS_HZ)))}
    world = BoxWorld(SimObject(box_spec(0), dict.fromkeys(FINGERS, NO_CONTACT_MM)), rng,
                     angles_deg={f: float(rng.uniform(-20, 20)) for f in FINGERS},
                     heights_mm={f: float(rng.uniform(1.0, 4.0)) for f in FINGERS},
                     audio_seed=seed, chain_options=chain, boxes=boxes,
                     amplitude_gain=float(rng.uniform(*TASK_AMPLITUDE_GAIN)),
                     scene_seed=int(rng.integers(1 << 30)))
    hand = SimHand(world, {f: hand_seed + i for i, f in enumerate(FINGERS)})
    return world, hand, SimArm(world)


def shake_model_path(recordings_per_class: int = 20) -> Path:
    """The shake classifier (an MLP over 86-frame windows; :mod:`fingertip.models.vibration.shake`),
    trained once on simulated shakes like the paper's training set (20 per class: screws,
    rubber bands, empty; 5.6 s; grips 1-2 N; default fills and amplitude) and cached under
    :func:`cache_dir`. Deterministic: about 5 s the first time."""
    from ... import __version__, models
    from ...models.nets.fit_cache import fit_key
    from ...models.vibration.shake import train_shake
    from .. import dataset, physics
    from ..dataset import write_vibration

    # Keyed by the training set's parameters and by the code that simulates and trains it, so
    # a classifier trained by older code is never reused (as the force models' cache is).
    key = fit_key({"seed": SHAKE_MODEL_SEED, "recordings_per_class": recordings_per_class,
                   "models": "mlp", "train_seed": 0},
                  [Path(physics.__file__).parent, Path(dataset.__file__),
                   Path(models.__file__).parent], __version__)

    def build(folder: Path) -> None:
        log.info("training the shake classifier on simulated shakes in %s", folder)
        write_vibration(folder / "data", kind="shake", recordings_per_class=recordings_per_class,
                        seed=SHAKE_MODEL_SEED)
        train_shake(folder / "data", folder / "model", models=("mlp",), plot=False, seed=0)
        shutil.rmtree(folder / "data")
        # the product sits at the top of the entry, as the cache expects
        for item in (folder / "model").iterdir():
            os.replace(item, folder / item.name)
        (folder / "model").rmdir()

    return cached(f"shake-mlp-{SHAKE_MODEL_SEED}-{recordings_per_class}-{key}", "shake_mlp.onnx",
                  build)
