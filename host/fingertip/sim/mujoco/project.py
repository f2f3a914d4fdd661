"""The one place where ``sim/mujoco`` reaches the rest of the project.

The fingertip's dimensions (the same file the CAD reads), its strain and piezo physics, the
error sources, the sliding materials, the virtual world's objects, force models and
demonstration, the recipes and the robot interfaces are imported here and nowhere else in this
package, so that a move of those modules changes one file.
"""
from __future__ import annotations

from ...audio import SimulatedSource
from ...hardware.params import FingertipParams
from ...hardware.params import load as load_params
from ...device import Frame
from ...tasks.cups import CupConfig, unstack
from ...tasks.grip import PinchConfig
from ...tasks.hold import HoldConfig, hold
from ...tasks.interfaces import AudioBlock, FrameSet, RobotArm, RobotHand
from ...tasks.pinch import pinch
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
from ..physics.vibration import AudioChain, good_fft_size, half_sine, place
from ..world.demonstration import demonstrate
from ..world.hand import CHIP, TOFU, unit_force_model

__all__ = [
    "CHIP", "CUP_WALL", "MATERIALS", "PAPER_SEVEN", "REF_NORMAL_N", "REF_SPEED_MM_S", "TOFU",
    "AudioBlock", "AudioChain", "CupConfig", "demonstrate", "HELD_OBJECTS", "hold", "HoldConfig",
    "FingertipParams", "Frame", "FrameSet",
    "good_fft_size", "half_sine", "load_params", "load_realism", "Material", "material_named",
    "pinch", "PinchConfig", "place", "Realism", "RobotArm", "RobotHand", "unit_force_model",
    "SimulatedSource", "unstack", "VirtualStrainSensor",
]
