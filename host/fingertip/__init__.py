"""fingertip: host bridge of the open-source multi-modal tactile fingertip.

Layers (lower never import higher): ``protocol`` (pure codec) <- transport, audio <- device
<- models, events <- tasks; ``sim`` is the virtual fingertip; ``cli`` is the thin command line.
"""
import logging

__version__ = "0.1.0"

logging.getLogger(__name__).addHandler(logging.NullHandler())

_LAZY = {
    "BridgeStats": "device", "CommandFailed": "device", "CommandTimeout": "device",
    "FingerFrame": "device", "Fingertip": "device", "FingertipError": "device",
    "Frame": "device", "Hand": "device", "NotConnected": "device",
    "ProtocolVersionError": "protocol",
}
"""The public names, imported on first use: ``import fingertip`` stays cheap, so the command
line handles Ctrl-C before the heavier layers load (an interrupt while they import would be
a traceback). A plain literal: tests/test_import_layers.py reads it to know which package
each name comes from."""

__all__ = ["BridgeStats", "CommandFailed", "CommandTimeout", "FingerFrame", "Fingertip",
           "FingertipError", "Frame", "Hand", "NotConnected", "ProtocolVersionError", "__version__"]


def __getattr__(name: str):
    import importlib

    if name in _LAZY:
        value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
