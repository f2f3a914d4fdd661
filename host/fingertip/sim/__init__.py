"""Simulated fingertip hardware: :mod:`.physics` (strain and vibration), :mod:`.device` (the
virtual fingertip and its calibration bench), :mod:`.world` (the hand, arm and objects the task
recipes run in)."""
from .device import VirtualFirmware, device_lib

__all__ = ["FIRMWARE_VERSION", "VirtualFirmware", "device_lib"]


def __getattr__(name: str) -> object:
    if name == "FIRMWARE_VERSION":  # from the C++, loaded on first use
        from .device import virtual_firmware
        return virtual_firmware.FIRMWARE_VERSION
    raise AttributeError(name)
