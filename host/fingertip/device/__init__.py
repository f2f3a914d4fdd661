"""Device layer: a fingertip's commands, streams, counters and clock mapping."""
from .timesync import ClockFit, ClockSync, Unwrapper

__all__ = ["ClockFit", "ClockSync", "Unwrapper"]
