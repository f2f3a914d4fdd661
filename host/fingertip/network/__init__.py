"""The fingertip live on a robot's network: ROS 2 over DDS or Zenoh, and Lab Streaming Layer.

Topic names, message types and payloads are those ``fingertip record`` writes
(:mod:`fingertip.record.schemas` is the one source of truth): a subscriber on the network
gets, byte for byte, the CDR messages that a local recording holds.

The transports' libraries are optional extras (``fingertip[ros]``, ``fingertip[zenoh]``,
``fingertip[lsl]``);
:func:`require` turns a missing one into one clear line.
"""
from __future__ import annotations

import importlib

from ..errors import Error
from types import ModuleType

TRANSPORTS = ("dds", "zenoh", "lsl")
"""The transports ``fingertip publish --transport`` offers."""

EXTRAS = {"cyclonedds": "ros", "zenoh": "zenoh", "pylsl": "lsl", "rosbags": "ros"}
"""Python module -> the extra of ``fingertip`` that installs it."""


class ExtraMissing(Error, ImportError):
    """An optional dependency is not installed (the message names the extra; exit status
    2: the user's installation)."""

    exit_code = 2


def require(module: str, what: str) -> ModuleType:
    """Import ``module`` or raise :class:`ExtraMissing` naming the extra that brings it."""
    try:
        return importlib.import_module(module)
    except ImportError as e:
        extra = EXTRAS.get(module.split(".")[0], module)
        raise ExtraMissing(f"{what} needs the Python package {module.split('.')[0]!r}, which "
                           f"is not installed: pip install 'fingertip[{extra}]' ({e})") from e
