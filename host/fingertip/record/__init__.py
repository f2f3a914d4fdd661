"""Recording, replay and export: fingertip data in MCAP files with ROS 2 messages.

* :class:`Recorder`: frames (``/fingertip/<name>/raw``), forces (``.../wrench``,
  geometry_msgs/WrenchStamped), audio (``.../audio``), events (``.../events``) and device
  info (``.../info``) into one MCAP file, ROS 2 CDR with the message definitions embedded;
  flushed in chunks so that a killed recorder leaves a readable file.
* :class:`Recording`: reads a file (also one cut short by a crash) as decoded messages.
* :class:`Replay`: a recording played back as a live :class:`~fingertip.Fingertip` (and a
  live audio source), for the same user code.
* :func:`export`: CSV per fingertip, WAV per audio stream, events CSV.

See docs/recording.md. This layer sits above ``device`` and ``audio``. Its names are
imported on first use, so that ``fingertip.cli.record`` (the argument parsers) stays cheap
to import for the command line.
"""
from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_WHERE = {
    "ExportError": "export", "ExportResult": "export", "export": "export",
    "ChannelInfo": "reader", "Record": "reader", "Recording": "reader",
    "RecordingError": "reader",
    "ForceModel": "encoding", "Recorder": "recorder", "RecorderError": "stats",
    "RecorderStats": "stats",
    "RecordedEvent": "replay", "Replay": "replay", "ReplayAudioSource": "replay",
    "Wrench": "replay",
    "SCHEMAS": "schemas", "TOPIC_KINDS": "schemas", "topic": "schemas",
    "TimeBase": "timebase",
}

__all__ = [
    "SCHEMAS", "TOPIC_KINDS", "ChannelInfo", "ExportError", "ExportResult", "ForceModel",
    "Record", "RecordedEvent", "Recorder", "RecorderError", "RecorderStats", "Recording",
    "RecordingError", "Replay", "ReplayAudioSource", "TimeBase", "Wrench", "export", "topic",
]


def __getattr__(name: str) -> Any:
    mod = _WHERE.get(name)
    if mod is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    module = importlib.import_module(f".{mod}", __name__)
    # Bind every public name of that module at once: importing a submodule sets the package
    # attribute of the same name (``export``) to the module, which would otherwise shadow
    # the function when another name of it (``ExportError``) was asked for first.
    for public, where in _WHERE.items():
        if where == mod:
            globals()[public] = getattr(module, public)
    return globals()[name]


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_WHERE))


if TYPE_CHECKING:  # for type checkers and IDEs
    from .export import ExportError, ExportResult, export
    from .reader import ChannelInfo, Record, Recording, RecordingError
    from .encoding import ForceModel
    from .recorder import Recorder
    from .stats import RecorderError, RecorderStats
    from .replay import RecordedEvent, Replay, ReplayAudioSource, Wrench
    from .schemas import SCHEMAS, TOPIC_KINDS, topic
    from .timebase import TimeBase
