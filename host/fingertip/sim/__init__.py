"""The virtual fingertip: a device that behaves like the firmware, and (later) its physics."""
from .virtual_firmware import FIRMWARE_VERSION, VirtualFirmware

__all__ = ["FIRMWARE_VERSION", "VirtualFirmware"]
