"""Stream sessions (``fingertip stream``): a fingertip's or a hand's live frames shown as
lines, JSON objects or a live status line, with forces from a calibration and a live plot.

The command line parses its options into a :class:`StreamSettings` and makes one call,
:func:`stream_fingertip` or :func:`stream_hand`; the frames' text is :mod:`.text`, the live
plot :mod:`.plot`.
"""
from .hand import HandStreamSummary, stream_hand
from .session import StreamError, StreamSettings, StreamSummary, stream_fingertip
from .text import frame_json, frame_line

__all__ = ["HandStreamSummary", "StreamError", "StreamSettings", "StreamSummary",
           "frame_json", "frame_line", "stream_fingertip", "stream_hand"]
