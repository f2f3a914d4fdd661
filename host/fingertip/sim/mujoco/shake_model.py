"""The shake classifier trained on MuJoCo shakes, and what the recipe hears of each shake.

Today's world's classifier is trained on scripted shakes in which every item crosses the box
and hits a wall around every turnaround. In MuJoCo the contents move as their friction and
mass let them at the paper's gentle shake (5 cm at 0.67 Hz: 0.09 g at the turnarounds):
rolling screws hit the walls less often than the script says, and grippy rubber bands (their
friction 1.0 > 0.09) barely slide at all (docs/mujoco.md has the figures). The classifier is
then trained where its recordings come from, as the paper trained its own on its boxes: the
same training code (:func:`~fingertip.models.vibration.shake.train_shake`, the MLP), on
shakes recorded here by the recipe itself (:class:`RecordingHand`: the audio ``read_box``
hears while it shakes), ``per_class`` per class (screws, rubber bands, an empty box) with the
world's training fills (8 screws, 10 rubber bands), random start gaps and the default
microphone, from seeds that no trial uses.
"""
from __future__ import annotations

import logging
import os
import shutil
import tempfile
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .boxes import BOX_X, BoxFill
from .project import (
    AudioBlock,
    LiveShakeClassifier,
    RobotArm,
    RobotHand,
    ShakeConfig,
    majority_vote,
    cache_dir,
    cached,
    fit_key,
    read_box,
    train_shake,
    version,
)

log = logging.getLogger(__name__)

TRAIN_FILLS = {"screws": 8, "rubber_bands": 10, "empty": 0}
"""As the world's training shakes (``BoxShake``'s defaults)."""
TRAIN_SEED = 1_000_000
"""Recording ``k`` of a class uses seed ``TRAIN_SEED + k``: no trial's."""
PER_CLASS = 12


class RecordingHand(RobotHand):
    """A hand that keeps what its fingertips' microphones gave the recipe during each shake
    (``shakes``: per shake the arm started, per finger, the blocks read after its start;
    :class:`ShakeMarkingArm` marks the starts)."""

    def __init__(self, hand: RobotHand) -> None:
        self.hand = hand
        self.shakes: list[dict[str, list[AudioBlock]]] = []

    @property
    def fingers(self) -> list[str]:
        return self.hand.fingers

    def step(self, increments_mm: Mapping[str, float]) -> None:
        self.hand.step(increments_mm)

    def positions(self) -> dict[str, float]:
        return self.hand.positions()

    def read(self, timeout: float = 0.5):
        return self.hand.read(timeout)

    def force_model(self, finger: str):
        return self.hand.force_model(finger)

    def read_audio(self, finger: str) -> AudioBlock:
        b = self.hand.read_audio(finger)
        if self.shakes:
            self.shakes[-1].setdefault(finger, []).append(b)
        return b

    def open_fully(self) -> None:
        self.hand.open_fully()

    def audio(self, shake: int, finger: str) -> AudioBlock:
        """What ``finger``'s microphone gave during shake ``shake``, joined."""
        blocks = [b for b in self.shakes[shake].get(finger, []) if len(b.samples)]
        if not blocks:
            return AudioBlock(np.zeros(0, np.float32), 44100.0, 0.0)
        return AudioBlock(np.concatenate([b.samples for b in blocks]), blocks[0].fs,
                          blocks[0].t0)


class ShakeMarkingArm(RobotArm):
    """An arm that tells a :class:`RecordingHand` when each shake starts."""

    def __init__(self, arm: RobotArm, hand: RecordingHand) -> None:
        self.arm, self.hand = arm, hand

    def move_to(self, x_mm: float, y_mm: float, z_mm: float) -> None:
        self.arm.move_to(x_mm, y_mm, z_mm)

    def position(self) -> tuple[float, float, float]:
        return self.arm.position()

    def slide_z(self, dz_mm: float, speed_mm_s: float) -> None:
        self.arm.slide_z(dz_mm, speed_mm_s)

    def shake(self, amplitude_mm: float, frequency_hz: float, duration_s: float) -> None:
        self.hand.shakes.append({})
        self.arm.shake(amplitude_mm, frequency_hz, duration_s)

    def moving(self) -> bool:
        return self.arm.moving()

    def stop(self) -> None:
        self.arm.stop()


def vote(clf, block: AudioBlock, step_s: float) -> tuple[str | None, dict[str, float]]:
    """A classifier's majority vote over one shake's audio, predicting every ``step_s`` on
    the latest window as the recipe does live, and each class's share of the predictions."""
    live = LiveShakeClassifier(clf, step_s)
    if len(block.samples):
        live.feed(block.samples, block.fs, block.t0)
    p = live.probabilities()
    if not len(p):
        return None, {}
    shares = {c: float(np.mean(p.argmax(axis=1) == i)) for i, c in enumerate(clf.classes)}
    return clf.classes[majority_vote(p)], shares


def record_shake(content: str, items: int, seed: int, clf) -> np.ndarray:
    """One shake of a box of ``items`` ``content`` as the recipe hears it (44.1 kHz)."""
    from .shake_trials import GRIP_Z_MM, ShakeTrial, hand_config, set_up

    fill = BoxFill("screws" if content == "empty" else content, items)
    tr = ShakeTrial.draw(seed)
    tr.fills = (fill, BoxFill("screws", 0))
    world, hand, arm, _ = set_up(tr, default_chain=True)
    rec = RecordingHand(hand)
    cfg: ShakeConfig = hand_config()
    r = read_box(rec, ShakeMarkingArm(arm, rec), clf, (BOX_X[0] * 1e3, 0.0, GRIP_Z_MM), cfg)
    if r.failure:
        raise RuntimeError(f"recording a {content} shake (seed {seed}): {r.failure}")
    return rec.audio(0, cfg.listen).samples


def write_shakes(folder: Path, per_class: int = PER_CLASS, clf=None) -> None:
    """``folder/<class>/<class>_NNNN.wav``: the training shakes."""
    import soundfile as sf

    for content, items in TRAIN_FILLS.items():
        (folder / content).mkdir(parents=True, exist_ok=True)
        for k in range(per_class):
            audio = record_shake(content, items, TRAIN_SEED + k, clf)
            sf.write(folder / content / f"{content}_{k:04d}.wav", audio, 44100,
                     subtype="PCM_16")


def mujoco_shake_model_path(per_class: int = PER_CLASS) -> Path:
    """The MLP shake classifier trained on MuJoCo shakes (cached; minutes the first time)."""
    from . import __file__ as here
    from .project import (
        VibrationClassifier,
        models_dir,
        physics_dir,
        shake_model_path,
        tasks_dir,
    )

    # The recipe records the shakes (read_box), so its code is part of the key.
    key = fit_key({"per_class": per_class, "seed": TRAIN_SEED, "fills": TRAIN_FILLS,
                   "models": "mlp", "train_seed": 0},
                  [Path(here).parent, physics_dir(), models_dir(), tasks_dir()], version())

    world_model = shake_model_path()
    name = f"mujoco-shake-mlp-{per_class}-{key}"
    # Built before the cache's (non-re-entrant) lock is taken: recording uses cached force
    # models itself; the cache then only takes the finished folder.
    if not (cache_dir() / name / "shake_mlp.onnx").is_file():
        cache_dir().mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f"{name}-build-", dir=cache_dir()))
        try:
            # read_box needs a classifier to run; its votes are not used here.
            clf = VibrationClassifier(world_model, kind="shake")
            log.info("recording %d MuJoCo shakes per class in %s", per_class, tmp)
            write_shakes(tmp / "data", per_class, clf)
            train_shake(tmp / "data", tmp / "model", models=("mlp",), plot=False, seed=0)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise

        def build(folder: Path) -> None:
            for item in (tmp / "model").iterdir():
                os.replace(item, folder / item.name)
            shutil.rmtree(tmp)
    else:
        def build(folder: Path) -> None:
            raise RuntimeError(f"{name} vanished from the cache while in use")

    return cached(name, "shake_mlp.onnx", build)
