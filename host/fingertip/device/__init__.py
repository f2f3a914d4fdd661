"""Device layer: a fingertip's commands, streams, counters and clock mapping."""
from .errors import CommandFailed, CommandTimeout, FingertipError, NotConnected
from .fingertip import Fingertip
from .frames import Frame
from .hand import FingerFrame, Hand
from .reader import SharedReader
from .state import BridgeStats, Settings
from .timesync import ClockFit, ClockSync, Unwrapper

__all__ = ["BridgeStats", "ClockFit", "ClockSync", "CommandFailed", "CommandTimeout",
           "FingerFrame", "Fingertip", "FingertipError", "Frame", "Hand", "NotConnected",
           "Settings", "SharedReader", "Unwrapper"]
