"""Device layer: a fingertip's commands, streams, counters and clock mapping."""
from .fingertip import (
    BridgeStats, CommandFailed, CommandTimeout, Fingertip, FingertipError, Frame, NotConnected,
    Settings,
)
from .hand import FingerFrame, Hand
from .reader import SharedReader
from .timesync import ClockFit, ClockSync, Unwrapper

__all__ = ["BridgeStats", "ClockFit", "ClockSync", "CommandFailed", "CommandTimeout",
           "FingerFrame", "Fingertip", "FingertipError", "Frame", "Hand", "NotConnected",
           "Settings", "SharedReader", "Unwrapper"]
