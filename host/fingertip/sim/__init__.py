"""Simulated fingertip hardware."""
from .virtual_firmware import VirtualFirmware

__all__ = ["FIRMWARE_VERSION", "VirtualFirmware"]


def __getattr__(name: str) -> object:
    if name == "FIRMWARE_VERSION":  # from the C++, loaded on first use
        from . import virtual_firmware
        return virtual_firmware.FIRMWARE_VERSION
    raise AttributeError(name)
