"""The virtual fingertip as a device, and the bench it is calibrated on.

- :mod:`.device_lib`, :mod:`.virtual_firmware`: the firmware's own C++ device logic through
  ctypes (``VirtualFirmware``), fed by the strain physics;
- :mod:`.memory_link`, :mod:`.pty_device`: that device on an in-memory stream or a
  pseudo-terminal; :mod:`.simavr`, :mod:`.simavr_check`: the real firmware ELF in simavr;
- :mod:`.faults`: wiring and part faults a bring-up check must find; :mod:`.bringup`: a
  virtual unit that the check (and a guided calibration) drives;
- :mod:`.audio_feed`, :mod:`.scene_audio`: the contact microphone's sound card (PulseAudio
  feed, a scene's audio as a capture source);
- the calibration bench: :mod:`.calibration_rig` (the paper's indenter sweep) and
  :mod:`.reference_rig` (presses beside a virtual reference F/T sensor, :mod:`.rdt_server`).

Inside ``sim`` this sits above :mod:`fingertip.sim.physics` and below the world.
"""
from . import device_lib
from .virtual_firmware import VirtualFirmware

__all__ = ["VirtualFirmware", "device_lib"]
