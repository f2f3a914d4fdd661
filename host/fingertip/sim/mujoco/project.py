"""The one place where ``sim/mujoco`` reaches the rest of the project.

The fingertip's dimensions (the same file the CAD reads), its strain and piezo physics, the
error sources, the sliding materials, the virtual world's objects, force models and
demonstration, the recipes and the robot interfaces are imported here and nowhere else in this
package, so that a move of those modules changes one file.
"""
from __future__ import annotations

from pathlib import Path

from ...audio import SimulatedSource
from ...hardware.params import FingertipParams
from ...hardware.params import load as load_params
from ...device import Frame
from ...tasks.cups import CupConfig, unstack
from ...tasks.grip import PinchConfig
from ...tasks.hold import HoldConfig, hold
from ...tasks.interfaces import AudioBlock, FrameSet, RobotArm, RobotHand
from ...tasks.pinch import pinch
from ...tasks.shake_pick import LiveShakeClassifier, ShakeConfig, read_box, shake_and_pick
from ...models.vibration.classify import VibrationClassifier, majority_vote
from ..physics.grasp import HELD_OBJECTS
from ..physics.materials import (
    CUP_WALL,
    MATERIALS,
    PAPER_SEVEN,
    REF_NORMAL_N,
    REF_SPEED_MM_S,
    Material,
)
from ..physics.materials import material as material_named
from ..physics.realism import Realism
from ..physics.realism import load as load_realism
from ..physics.strain import VirtualStrainSensor
from ..physics.task_scenes import (
    BAND_PULSE_S,
    BOX_LOWPASS_HZ,
    BOX_WALL_MODES,
    CREAK_N,
    ITEM_MASS_KG,
    RATTLE_N,
    RATTLE_PULSE_S,
    SCREW_PULSE_S,
    SCREW_RING_GAIN,
    SCREW_RING_HZ,
    grip_transmission,
    impact_pulse_n,
    screw_ring,
)
from ..physics.vibration import AudioChain, good_fft_size, half_sine, place, smooth_noise
from ..world.boxes import make_box_world, shake_model_path
from ..world.cache import cache_dir, cached
from ..world.demonstration import demonstrate
from ..world.hand import CHIP, TOFU, unit_force_model

__all__ = [
    "BAND_PULSE_S", "BOX_LOWPASS_HZ", "BOX_WALL_MODES", "CREAK_N", "ITEM_MASS_KG", "RATTLE_N",
    "RATTLE_PULSE_S", "SCREW_PULSE_S", "SCREW_RING_GAIN", "SCREW_RING_HZ",
    "grip_transmission", "impact_pulse_n", "screw_ring", "smooth_noise",
    "CHIP", "CUP_WALL", "MATERIALS", "PAPER_SEVEN", "REF_NORMAL_N", "REF_SPEED_MM_S", "TOFU",
    "AudioBlock", "AudioChain", "CupConfig", "demonstrate", "HELD_OBJECTS", "hold", "HoldConfig",
    "FingertipParams", "Frame", "FrameSet",
    "good_fft_size", "half_sine", "load_params", "load_realism", "Material", "material_named",
    "pinch", "PinchConfig", "place", "Realism", "RobotArm", "RobotHand", "unit_force_model",
    "SimulatedSource", "unstack", "VirtualStrainSensor",
    "cache_dir", "cached", "fit_key", "LiveShakeClassifier", "models_dir", "physics_dir",
    "tasks_dir",
    "read_box",
    "train_shake", "version", "majority_vote",
    "ShakeConfig", "shake_and_pick", "VibrationClassifier", "make_box_world", "shake_model_path",
]


def version() -> str:
    from ... import __version__

    return __version__


def physics_dir() -> Path:
    from .. import physics

    return Path(physics.__file__).parent


def tasks_dir() -> Path:
    from ... import tasks

    return Path(tasks.__file__).parent


def models_dir() -> Path:
    from ... import models

    return Path(models.__file__).parent


def fit_key(*args, **kwargs) -> str:
    from ...models.nets.fit_cache import fit_key as key

    return key(*args, **kwargs)


def train_shake(*args, **kwargs):
    from ...models.vibration.shake import train_shake as train

    return train(*args, **kwargs)
