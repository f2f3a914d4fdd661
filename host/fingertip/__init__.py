"""fingertip: host bridge of the open-source multi-modal tactile fingertip.

Layers (lower never import higher): ``protocol`` (pure codec) <- transport, audio <- device
<- models, events <- tasks; ``sim`` is the virtual fingertip; ``cli`` is the thin command line.
"""
import logging

__version__ = "0.1.0"

logging.getLogger(__name__).addHandler(logging.NullHandler())

from .device import (  # noqa: E402  (after the version, which submodules may read)
    BridgeStats, CommandFailed, CommandTimeout, FingerFrame, Fingertip, FingertipError, Frame,
    Hand, NotConnected,
)
from .protocol import ProtocolVersionError  # noqa: E402

__all__ = ["BridgeStats", "CommandFailed", "CommandTimeout", "FingerFrame", "Fingertip",
           "FingertipError", "Frame", "Hand", "NotConnected", "ProtocolVersionError", "__version__"]
