"""Physics of the virtual fingertip: strain-gauge forces and contact-microphone vibrations.

- the fingertip's parameters (``fingertip.toml``: dimensions, parts, their mechanical and
  electrical properties) come from :mod:`fingertip.hardware`, shared with the CAD and the PCB.
- :mod:`.strain`: cantilever prism -> gauge strain -> quarter bridge -> HX711 counts, with
  per-unit variation, cross-talk, hysteresis, creep, temperature drift, noise, saturation.
- :mod:`.realism`: the one set of switches for every imperfection (:class:`Realism`; all on
  by default) and the sizes of the documented error sources of a real unit (``realism.toml``).
- :mod:`.vibration`, :mod:`.materials`: dynamic force at the nail -> cap modes -> piezo ->
  preamp (gain, clipping, hum, noise) -> sound-card samples.
- :mod:`.scenes`, :mod:`.simulate`: scenes declare the signals they need; only those are
  computed.

Imports numpy, the standard library and :mod:`fingertip.hardware` only. See docs/simulation.md.
"""
from .materials import MATERIALS, PAPER_SEVEN, Material, material
from ...hardware import FingertipParams, load, params_path
from .realism import Realism
from .scenes import (
    FORCE,
    SIGNALS,
    VIBRATION,
    ContactMakeBreak,
    CustomForce,
    Forces,
    Idle,
    Press,
    Scene,
    Script,
    Slide,
)
from .task_scenes import BOX_CONTENTS, BoxShake, CupStackSlide
from .simulate import AudioTrace, ForceTrace, SimResult, simulate
from .strain import UnitVariation, VirtualStrainSensor, cap_deflection_m
from .vibration import AudioChain, Excitation

__all__ = [
    "BOX_CONTENTS", "FORCE", "MATERIALS", "PAPER_SEVEN", "SIGNALS", "VIBRATION",
    "AudioChain", "AudioTrace", "BoxShake", "ContactMakeBreak", "CupStackSlide", "CustomForce",
    "Excitation", "FingertipParams", "ForceTrace", "Forces", "Idle", "Material",
    "Press", "Realism", "Scene", "Script", "SimResult", "Slide", "UnitVariation",
    "VirtualStrainSensor", "cap_deflection_m", "load", "material",
    "params_path", "simulate",
]
