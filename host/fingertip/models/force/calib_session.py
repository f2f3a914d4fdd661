"""A ``calibrate record`` run from start to fit: the fingertip (live, or a ``fingertip
export`` CSV) and a reference (any :class:`~fingertip.reference.WrenchSource`, or a CSV)
joined by time (:func:`.calib_record.align_and_join`), then fitted and summed up.

The command line opens the devices and the reference source (a ROS 2 topic comes from the
network layer, a virtual rig from the simulator) and hands them here; errors are raised
(``ReferenceError``, ``AlignmentError``, ``CalibrationError``, ``OSError``) for it to turn
into exit codes.
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from ...reference import load_reference_csv
from .align import Joined
from .calib_record import (
    FingertipRecording,
    align_and_join,
    fit_joined,
    load_fingertip_csv,
    record_session,
)
from .calibrate import CalibrationReport

log = logging.getLogger(__name__)

Say = Callable[[str], None]


@dataclass(frozen=True)
class JoinedRun:
    """A fingertip recording joined to its reference, and where each came from."""

    fingertip: FingertipRecording
    joined: Joined
    serial: str
    sources: tuple[str, ...]

    def alignment_text(self) -> str:
        al = self.joined.alignment
        return (f"clock offset: reference = fingertip {al.offset_s * 1e3:+.1f} ms "
                f"+- {al.uncertainty_s * 1e3:.1f} ms (R2 {al.r2:.4f}); joined "
                f"{len(self.joined.times_s)} rows, dropped "
                + ", ".join(f"{v} {k}" for k, v in self.joined.dropped.items()))


def join_csvs(fingertip_csv: str | Path, reference_csv: str | Path, *,
              time_column: str = "host_time", serial: str = "",
              max_lag_s: float = 2.0) -> JoinedRun:
    """A fingertip exported to CSV and a reference CSV, joined."""
    rec = load_fingertip_csv(fingertip_csv, time_column)
    ref = load_reference_csv(reference_csv)
    return JoinedRun(rec, align_and_join(rec, ref, max_lag_s=max_lag_s), serial,
                     (str(reference_csv),))


def record_and_join(ft, source, duration_s: float, *, serial: str,
                    reference_csv: str | Path | None = None, max_lag_s: float = 2.0,
                    before: Callable[[], None] | None = None,
                    progress: Say | None = None) -> JoinedRun:
    """Record the open fingertip ``ft`` beside ``source`` for ``duration_s`` (``before``
    runs after the tare, as recording starts) and join the two; with ``reference_csv`` the
    reference is that file instead of what ``source`` sent."""
    rec, ref = record_session(ft, source, duration_s, before=before, progress=progress)
    sources: tuple[str, ...] = (source.name,)
    if progress is not None:
        progress(f"reference: {len(ref)} samples, {ref.counters.get('lost', 0)} lost")
    if reference_csv:
        ref = load_reference_csv(reference_csv)
        sources = (str(reference_csv),)
    return JoinedRun(rec, align_and_join(rec, ref, max_lag_s=max_lag_s), serial, sources)


def fit_run(run: JoinedRun, out_dir: str | Path, *, models: list[str],
            progress: Say | None = None) -> CalibrationReport:
    """Fit the joined rows and write the model and report files into ``out_dir``."""
    return fit_joined(run.joined, out_dir, gain=run.fingertip.gain, unit=run.serial,
                      device_serial=run.serial, sources=run.sources, models=models,
                      progress=progress)
