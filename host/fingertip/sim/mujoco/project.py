"""The one place where ``sim/mujoco`` reaches the rest of the project.

The fingertip's dimensions (the same file the CAD reads), its strain and piezo physics, the
error sources and the sliding materials are imported here and nowhere else in this package,
so that a move of those modules changes one file.
"""
from __future__ import annotations

from ..physics.materials import MATERIALS, PAPER_SEVEN, REF_NORMAL_N, REF_SPEED_MM_S, Material
from ..physics.materials import material as material_named
from ..physics.params import FingertipParams
from ..physics.params import load as load_params
from ..physics.realism import Realism
from ..physics.realism import load as load_realism
from ..physics.strain import Effects, VirtualStrainSensor
from ..physics.vibration import AudioChain, good_fft_size, half_sine, place
from ..world.hand import CHIP, TOFU

__all__ = [
    "CHIP", "MATERIALS", "PAPER_SEVEN", "REF_NORMAL_N", "REF_SPEED_MM_S", "TOFU", "AudioChain",
    "Effects",
    "FingertipParams", "Material", "Realism", "VirtualStrainSensor", "good_fft_size", "half_sine",
    "load_params", "load_realism", "material_named", "place",
]
