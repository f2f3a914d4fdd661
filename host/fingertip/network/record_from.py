"""The ``fingertip record --from dds|zenoh|lsl`` session: what ``fingertip publish`` sends,
recorded into the MCAP file a local recording writes, until Ctrl-C, SIGTERM or the end of a
duration."""
from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..record.recorder import Recorder
from ..record.schemas import check_name
from . import require
from .receive import NetworkRecorder
from .stopper import Stopper
from ..errors import NetworkError
from .waiting import Silence

log = logging.getLogger("fingertip")

SOURCE_MODULES = {"dds": "cyclonedds", "zenoh": "zenoh", "lsl": "pylsl"}
"""--from -> the module its extra installs."""


class NetworkStartError(NetworkError):
    """The network side (DDS, Zenoh, LSL) could not start, for example with bad settings
    (exit status 2: the settings the user gave)."""

    exit_code = 2


@dataclass
class NetworkRecording:
    """What a session recorded: messages written per topic kind, dropped and undecodable
    ones, and the recorder's error when writing failed part-way (None when it did not)."""

    written: dict[str, int]
    dropped: int
    undecodable: int
    error: BaseException | None
    timed_out: str | None = None
    """Why the session ended at ``--wait-timeout`` (one line), or None."""


def record_network(source: str, names: str, output: str | Path, *,
                   duration: float | None = None, flush_interval: float = 0.5,
                   flush_bytes: int = 1 << 20, compression: str = "zstd",
                   overwrite: bool = False, fsync: bool = False,
                   connect: Sequence[str] | None = None, listen: Sequence[str] | None = None,
                   wait_timeout: float | None = None,
                   say: Callable[[str], Any] = log.info) -> NetworkRecording:
    """Record the fingertips ``names`` (comma-separated) published over ``source`` into
    ``output``. Raises :class:`~fingertip.network.ExtraMissing` when the transport's extra
    is missing, ValueError or :class:`~fingertip.record.recorder.RecorderError` for a bad
    name or file, and :class:`NetworkStartError` when the network cannot start (then no new
    empty file is left behind).

    While a fingertip is silent (no publisher yet, or gone), a line every few seconds says
    what is awaited; with ``wait_timeout``, a fingertip silent that long ends the session
    (:attr:`NetworkRecording.timed_out`; a new file that got nothing is removed)."""
    # A SIGTERM while starting still ends cleanly; the caller's handler is back after.
    with Stopper(duration) as stopper:
        require(SOURCE_MODULES[source], f"record --from {source}")
        out = Path(output)
        existed = out.exists()
        checked = [check_name(s.strip()) for s in names.split(",")]
        rec = Recorder(out, flush_interval=flush_interval, flush_bytes=flush_bytes,
                       compression=compression, overwrite=overwrite, fsync=fsync).start()
        try:
            try:
                sink = NetworkRecorder(rec, source, checked, connect=connect, listen=listen)
            except Exception as e:  # DDS or Zenoh that cannot start (bad settings...)
                rec.close()
                if not existed:  # nothing was recorded: leave no empty file behind
                    out.unlink(missing_ok=True)
                raise NetworkStartError(str(e)) from e
            say(f"recording {', '.join(checked)} from {source} to {output}"
                + (f" for {duration:g} s" if duration else " (Ctrl-C to stop)"))
            silence = Silence(checked, source, time.monotonic(), timeout_s=wait_timeout)
            ended = None
            while ended is None and stopper.wait() and not rec.failed:
                now = time.monotonic()
                for name, t in list(sink.heard.items()):
                    if t is not None:
                        silence.heard(name, t)
                lines, ended = silence.check(now)
                for line in lines:
                    say(line)
            sink.close()
        finally:
            s = rec.close()
        if ended is not None and not existed and not s.written:
            out.unlink(missing_ok=True)  # nothing came: leave no empty file behind
        return NetworkRecording(dict(s.written), s.dropped_total, sink.bad, rec.error, ended)
