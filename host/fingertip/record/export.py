"""Export a recording to CSV and WAV files (one pass over the file, constant memory).

* ``<name>.csv`` per fingertip: ``unix_time, host_time, device_time_us, seq,
  arrival_time, ch0..chN, timeout_mask, saturation_mask`` and, when forces were recorded,
  ``fx, fy, fz, tx, ty, tz`` (the wrench stamped with the frame's time).
* ``<name>_audio.wav`` per audio stream, in the recorded sample format and rate (int16 ->
  PCM_16, int32 -> PCM_32 or the recorded subtype such as PCM_24, float32 -> FLOAT).
  Frame ``k`` of the WAV is recorded frame ``first_index0 + k``: frames lost during the
  recording are written as zeros so the WAV stays sample-exact.
  ``<name>_audio_chunks.csv`` gives each chunk's first index and host time, to align the
  WAV with the forces.
* ``events.csv``: every fingertip's events.

Times: ``unix_time`` is the stamp (seconds since 1970), ``host_time`` the recording host's
``time.monotonic()`` (what live code saw as ``Frame.host_time``).
"""
from __future__ import annotations

import contextlib
import csv
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import soundfile as sf

from ..badfile import BadFileError
from ..errors import Error, exit_code
from ..outputs import check_output, writable_folder
from . import schemas as S
from .reader import Recording

_SUBTYPES = {"int16": ("PCM_16",), "int32": ("PCM_32", "PCM_24"), "float32": ("FLOAT",)}


class ExportError(Error, RuntimeError):
    """The output folder cannot be written: a failure at run time (exit status 1), or the OS
    refusing the folder the user gave before anything is written (2)."""


@dataclass
class ExportResult:
    files: list[Path] = field(default_factory=list)
    frames: dict[str, int] = field(default_factory=dict)
    audio_frames: dict[str, int] = field(default_factory=dict)
    audio_gap_frames: dict[str, int] = field(default_factory=dict)
    events: int = 0
    unmatched_wrenches: int = 0
    """Wrenches whose stamp matched no frame (not written)."""
    truncated: bool = False


class _DeviceCsv:
    def __init__(self, path: Path, forces: bool) -> None:
        self.path = path
        self.forces = forces
        self.f = open(path, "w", newline="", encoding="utf-8")
        self.w = csv.writer(self.f)
        self.channels: int | None = None
        self.pending: tuple[int, list[Any]] | None = None
        self.rows = 0

    def frame(self, m: S.RawMsg, tb) -> None:
        self.flush_pending()
        if self.channels is None:
            self.channels = len(m.counts)
            head = ["unix_time", "host_time", "device_time_us", "seq", "arrival_time"]
            head += [f"ch{i}" for i in range(self.channels)]
            head += ["timeout_mask", "saturation_mask"]
            if self.forces:
                head += ["fx", "fy", "fz", "tx", "ty", "tz"]
            self.w.writerow(head)
        counts = list(m.counts[:self.channels])
        counts += [""] * (self.channels - len(counts))
        row = [f"{m.stamp_ns / S.NS:.9f}", f"{tb.to_monotonic(m.stamp_ns):.9f}",
               m.device_time_us, m.seq, f"{tb.to_monotonic(m.arrival_ns):.9f}", *counts,
               m.timeout_mask, m.saturation_mask]
        self.pending = (m.stamp_ns, row)

    def wrench(self, m: S.WrenchMsg) -> bool:
        if self.pending is None or self.pending[0] != m.stamp_ns or not self.forces:
            return False
        row = self.pending[1]
        row += [repr(v) for v in (*m.force, *m.torque)]
        self.pending = None
        self.w.writerow(row)
        self.rows += 1
        return True

    def flush_pending(self) -> None:
        if self.pending is not None:
            row = self.pending[1]
            if self.forces:
                row += [""] * 6
            self.w.writerow(row)
            self.rows += 1
            self.pending = None

    def close(self) -> None:
        self.flush_pending()
        self.f.close()


class _AudioWav:
    def __init__(self, path: Path, chunks_path: Path, m: S.AudioMsg,
                 meta: dict[str, str]) -> None:
        self.dtype = np.dtype(S.AUDIO_DTYPES[m.encoding])
        subtype = meta.get("subtype")
        if subtype not in _SUBTYPES[self.dtype.name]:
            subtype = _SUBTYPES[self.dtype.name][0]
        self.channels = m.channels
        self.wav = sf.SoundFile(str(path), "w", samplerate=int(round(m.sample_rate)),
                                channels=m.channels, subtype=subtype, format="WAV")
        self.cf = open(chunks_path, "w", newline="", encoding="utf-8")
        self.cw = csv.writer(self.cf)
        self.cw.writerow(["wav_index", "first_index", "frames", "unix_time", "host_time",
                          "host_rate", "lost_before"])
        self.first_index0 = m.first_index
        self.next_index = m.first_index
        self.frames = 0
        self.gap_frames = 0

    def chunk(self, m: S.AudioMsg, tb) -> None:
        block = np.frombuffer(m.data, dtype=self.dtype.newbyteorder("<")).reshape(
            m.frames, m.channels)
        if m.first_index < self.next_index:  # overlap (should not happen): keep the new part
            block = block[self.next_index - m.first_index:]
        elif m.first_index > self.next_index:
            gap = m.first_index - self.next_index
            self.wav.write(np.zeros((gap, self.channels), dtype=self.dtype))
            self.gap_frames += gap
            self.next_index += gap
        self.cw.writerow([m.first_index - self.first_index0, m.first_index, m.frames,
                          f"{m.stamp_ns / S.NS:.9f}", f"{tb.to_monotonic(m.stamp_ns):.9f}",
                          repr(m.host_rate), m.lost_before])
        if len(block):
            self.wav.write(np.ascontiguousarray(block, dtype=self.dtype))
            self.next_index += len(block)
            self.frames += len(block)

    def close(self) -> None:
        self.wav.close()
        self.cf.close()


def export(path: str | os.PathLike, out_dir: str | os.PathLike, *,
           overwrite: bool = True) -> ExportResult:
    """Write the CSV and WAV files of the recording at ``path`` into ``out_dir`` (created
    if needed). A folder that is not empty is refused unless ``overwrite`` (then files of
    the same names are replaced; the command line's ``--force``); a recording of which no
    message can be read is refused (BadFileError) and leaves no folder behind."""
    rec = Recording(path)
    out = check_output(out_dir, force=overwrite, inputs=[path], what="export folder",
                       folder=True)
    created = not out.exists()
    try:
        writable_folder(out)
    except OSError as e:
        # before anything is written: the OS refusing the user's folder is theirs (2)
        raise ExportError(f"cannot write into {out}: {e.strerror or e}",
                          exit_code=exit_code(e)) from e
    chans = rec.channels()
    forces = {c.name for c in chans.values() if c.kind == "wrench"}
    audio_meta = {c.name: c.metadata for c in chans.values() if c.kind == "audio"}
    tb = rec.timebase
    res = ExportResult()
    devices: dict[str, _DeviceCsv] = {}
    wavs: dict[str, _AudioWav] = {}
    events_f = None
    events_w = None
    try:
        for r in rec.records(kinds=("raw", "wrench", "audio", "events")):
            m = r.msg
            if r.kind == "raw":
                d = devices.get(r.name)
                if d is None:
                    p = out / f"{r.name}.csv"
                    d = devices[r.name] = _DeviceCsv(p, r.name in forces)
                    res.files.append(p)
                d.frame(m, tb)
            elif r.kind == "wrench":
                d = devices.get(r.name)
                if d is None or not d.wrench(m):
                    res.unmatched_wrenches += 1
            elif r.kind == "audio":
                a = wavs.get(r.name)
                if a is None:
                    p = out / f"{r.name}_audio.wav"
                    cp = out / f"{r.name}_audio_chunks.csv"
                    a = wavs[r.name] = _AudioWav(p, cp, m, audio_meta.get(r.name, {}))
                    res.files += [p, cp]
                a.chunk(m, tb)
            elif r.kind == "events":
                if events_w is None:
                    p = out / "events.csv"
                    events_f = open(p, "w", newline="", encoding="utf-8")
                    events_w = csv.writer(events_f)
                    events_w.writerow(["unix_time", "host_time", "fingertip", "kind", "value",
                                       "detail"])
                    res.files.append(p)
                events_w.writerow([f"{m.stamp_ns / S.NS:.9f}",
                                   f"{tb.to_monotonic(m.stamp_ns):.9f}", r.name, m.kind,
                                   repr(m.value), m.detail])
                res.events += 1
    except OSError as e:
        raise ExportError(f"writing into {out} failed: {e.strerror or e}") from e
    finally:
        for d in devices.values():
            d.close()
        for a in wavs.values():
            a.close()
        if events_f is not None:
            events_f.close()
    if not res.files:
        if created:
            with contextlib.suppress(OSError):
                out.rmdir()
        raise BadFileError(f"{path}: no fingertip message could be read (a damaged file, or "
                           "not a fingertip recording): nothing exported", path)
    res.frames = {n: d.rows for n, d in devices.items()}
    res.audio_frames = {n: a.frames for n, a in wavs.items()}
    res.audio_gap_frames = {n: a.gap_frames for n, a in wavs.items()}
    res.truncated = rec.truncated
    return res
