"""What a :class:`~fingertip.record.recorder.Recorder` reports: its counters, and the error
that stopped it."""
from __future__ import annotations

from dataclasses import dataclass, field

from ..errors import Error


class RecorderError(Error, RuntimeError):
    """The recording cannot start, or writing it failed (the message says why and where). A
    failure at run time (exit status 1) unless raised with ``exit_code=2``: an output path
    the user gave that is refused before anything is written."""


@dataclass
class RecorderStats:
    """Counters of a recorder (a snapshot)."""

    accepted: dict[str, int] = field(default_factory=dict)
    """Messages accepted into the queue, by topic (written soon, or lost to a failure)."""
    written: dict[str, int] = field(default_factory=dict)
    """Messages in chunks written to the file, by topic (those of the chunk in progress
    count once it is written)."""
    dropped: dict[str, int] = field(default_factory=dict)
    """Messages not written (queue full; or lost to a write error: then the chunk in
    progress, what was queued, and everything after), by topic."""
    bytes_written: int = 0
    """Bytes handed to the OS so far (the file size)."""
    flushes: int = 0
    """Chunks closed and written."""
    queue_high_water: int = 0
    encode_errors: int = 0
    """Messages that could not be encoded (bad values), or force-model failures."""
    audio_frames: dict[str, int] = field(default_factory=dict)
    """Audio frames handed to the file (including the chunk in progress), by name."""

    @property
    def dropped_total(self) -> int:
        return sum(self.dropped.values())

    @property
    def written_total(self) -> int:
        return sum(self.written.values())
