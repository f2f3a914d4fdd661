"""Simulated fingertip hardware."""
from . import device_lib
from .virtual_firmware import VirtualFirmware

__all__ = ["FIRMWARE_VERSION", "VirtualFirmware", "device_lib"]


def __getattr__(name: str) -> object:
    if name == "FIRMWARE_VERSION":  # from the C++, loaded on first use
        from . import virtual_firmware
        return virtual_firmware.FIRMWARE_VERSION
    raise AttributeError(name)
