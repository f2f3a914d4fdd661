"""One recording session (``fingertip record``): a fingertip and its microphone into one MCAP
file until a duration passes, SIGTERM or Ctrl-C, then a summary of what was written.

:func:`record_fingertip` opens the device, tares it, attaches it (and the audio source) to a
:class:`~fingertip.record.recorder.Recorder`, runs :func:`run_until` and returns a
:class:`FingertipSummary`. A hand is recorded by :func:`fingertip.record.hand_record.record_hand`
with the same settings and loop. Errors are raised (the caller chooses exit codes); what the
session says goes through callbacks, so the command line decides where it is printed.
"""
from __future__ import annotations

import contextlib
import json
import logging
import signal
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..badfile import check_input
from ..errors import Error

log = logging.getLogger(__name__)

Say = Callable[[str], None]


class SessionError(Error):
    """A user error found before recording (the output path, a refused force model): one
    line, exit status 2."""

    exit_code = 2


@dataclass(frozen=True)
class RecordSettings:
    """Where and how to record (the ``record`` command's options)."""

    output: Path
    name: str = "fingertip"
    duration: float | None = None   # seconds; None: until SIGTERM or Ctrl-C
    tare: int | None = None         # samples to tare with first
    flush_interval: float = 0.5
    flush_kb: int = 1024
    compression: str = "zstd"
    overwrite: bool = False
    fsync: bool = False

    def recorder(self):
        """A :class:`~fingertip.record.recorder.Recorder` writing to :attr:`output`."""
        from .recorder import Recorder

        return Recorder(self.output, flush_interval=self.flush_interval,
                        flush_bytes=self.flush_kb * 1024, compression=self.compression,
                        overwrite=self.overwrite, fsync=self.fsync)

    def announce(self, what: str) -> str:
        """The line said as recording starts."""
        return (f"recording {what} to {self.output}"
                + (f" for {self.duration:g} s" if self.duration else " (Ctrl-C to stop)"))


def check_output(path: Path, overwrite: bool, inputs: Iterable[str | Path] = ()) -> None:
    """Refuse a folder, a FIFO, a device, one of ``inputs``, or an existing file unless
    ``overwrite`` (before any device opens): :func:`fingertip.outputs.check_output`."""
    from ..errors import OutputRefused
    from ..outputs import check_output as check

    try:
        check(path, force=overwrite, inputs=inputs, what="recording")
    except OutputRefused as e:
        raise SessionError(str(e)) from e


def open_audio(device: str | None, file: str | None, *, rate: float, channels: int,
               dtype: str):
    """The microphone to record: a sound card (index or part of its name), a WAV/FLAC file
    played in real time, or None. Raises AudioError or ValueError."""
    from ..audio import FileSource, SoundDeviceSource

    if device is not None:
        dev: int | str = int(device) if device.isdigit() else device
        return SoundDeviceSource(dev, rate, channels=channels, dtype=dtype)
    if file:
        check_input(file, "a WAV or FLAC file")  # a FIFO would block open() for ever
        src = FileSource(file, realtime=True)
        warn_if_unusable(src)
        return src
    return None


WARN_READ_LIMIT = 20_000_000
"""Samples of an --audio-file read ahead to check it (beyond: not checked, only streamed)."""


def warn_if_unusable(src) -> None:
    """Warn when the audio file of ``src`` (a FileSource) is silent, constant, non-finite or
    clipped (:func:`~fingertip.audio.sanity.signal_problem`): it is recorded all the same,
    as it is what was asked for."""
    import soundfile as sf

    from ..audio.sanity import signal_problem

    if src.frames_total * src.channels > WARN_READ_LIMIT:
        return
    try:
        x, _ = sf.read(str(src.path), dtype="float64", always_2d=True)
    except (sf.SoundFileError, RuntimeError, OSError):
        return  # the source reports its own read errors when it plays
    if (problem := signal_problem(x, 1.0)) is not None:
        log.warning("%s: %s: recorded as it is, but check the file", src.path,
                    problem)


@contextlib.contextmanager
def sigterm_sets(stop: threading.Event) -> Iterator[None]:
    """While inside, SIGTERM sets ``stop`` (a recorder killed politely closes its file);
    the previous handler is restored on the way out. Signals can only be handled on the
    main thread, so elsewhere this does nothing."""
    old = None
    if threading.current_thread() is threading.main_thread():
        old = signal.signal(signal.SIGTERM, lambda *_: stop.set())
    try:
        yield
    finally:
        if old is not None:
            signal.signal(signal.SIGTERM, old)


def run_until(duration: float | None, rec, tick: Callable[[float], None] | None = None) -> float:
    """Wait until ``duration`` seconds pass (None: no limit), SIGTERM, Ctrl-C or the
    recorder fails, calling ``tick(seconds so far)`` about every 0.1 s; the elapsed seconds."""
    stop = threading.Event()
    t0 = time.monotonic()
    t_end = t0 + duration if duration else None
    with sigterm_sets(stop):
        try:
            while not stop.is_set():
                now = time.monotonic()
                if t_end is not None and now >= t_end:
                    break
                if rec.failed:
                    break
                if tick is not None:
                    tick(now - t0)
                stop.wait(0.1 if t_end is None else max(0.0, min(0.1, t_end - now)))
        except KeyboardInterrupt:
            pass
    return time.monotonic() - t0


@dataclass(frozen=True)
class FingertipSummary:
    """What one fingertip's session wrote; :attr:`error` is set when writing failed
    part-way (what was written before is readable)."""

    output: Path
    elapsed_s: float
    frames: int
    forces: int
    audio_s: float
    audio_chunks: int
    events: int
    dropped: int
    megabytes: float
    frames_lost: int
    crc_errors: int
    reconnects: int
    error: str | None = None
    device_resets: int = 0
    outage_frames: int = 0
    """Of ``frames_lost``, those missing across outages (link lost, device restarted)."""
    gone_s: float | None = None
    """Seconds the device had been away when the session ended (None: it was there)."""

    def text(self) -> str:
        from ..device.health import gone_text, link_text

        return (f"recorded {self.elapsed_s:.1f} s to {self.output}: {self.frames} frames, "
                f"{self.forces} forces, {self.audio_s:.1f} s of audio in {self.audio_chunks} "
                f"chunks, {self.events} events; dropped {self.dropped}; "
                f"{self.megabytes:.2f} MB; device: {link_text(self)}"
                + gone_text("the device", self.gone_s))


def _status_line(seconds: float, rec, ft, name: str, audio) -> str:
    s = rec.stats
    frames = s.accepted.get(f"/fingertip/{name}/raw", 0)
    audio_s = (s.audio_frames.get(name, 0) / audio.sample_rate) if audio else 0.0
    return (f"{seconds:7.1f} s  {frames:7d} frames"
            + (f"  audio {audio_s:6.1f} s" if audio else "")
            + f"  {s.bytes_written / 1e6:7.2f} MB  dropped {s.dropped_total}"
            + f"  [{ft.status}]   ")


def record_fingertip(settings: RecordSettings, *, port: str | None = None,
                     serial: str | None = None, audio=None, force_model: Any = None,
                     model_for: Callable[[Any], Any] | None = None, say: Say | None = None,
                     status: Say | None = None) -> FingertipSummary:
    """Record the fingertip on ``port`` (or with USB ``serial``) and ``audio`` (a source, not
    started) until the settings' duration, SIGTERM or Ctrl-C.

    ``model_for(ft)``, when given, returns the force model checked against the opened
    fingertip (it raises to refuse it); otherwise ``force_model`` is used as it is.
    ``say`` gets the start line, ``status`` a progress line about every 0.25 s. Raises the
    device's, recorder's and audio errors; the device is closed whatever happens.
    """
    from ..device import Fingertip, FingertipError
    from ..device.health import GoneReporter

    ft = (Fingertip(serial_number=serial, name=settings.name) if serial
          else Fingertip(port, name=settings.name)).open()
    rec = None
    try:
        if model_for is not None:  # before anything is written: a refused model writes nothing
            force_model = model_for(ft)
        try:
            offsets = ft.tare(samples=settings.tare) if settings.tare else None
            rec = settings.recorder()
            rec.start()
            name = rec.attach(ft, settings.name, force_model=force_model)
            if offsets is not None:
                rec.write_event(name, "tare", float(settings.tare),
                                detail=json.dumps(list(offsets)))
            if audio is not None:
                audio.start()
                rec.record_audio(audio, name)
            ft.start()
            rec.write_event(name, "start")
            if say is not None:
                say(settings.announce(f"{name} from {ft.port}"))
            reconnects = ft.stats.reconnects
            last_status = -1.0
            gone = GoneReporter()

            def tick(seconds: float) -> None:
                nonlocal reconnects, last_status
                gone.check(ft.name, ft.gone_s, ft.port)
                if ft.stats.reconnects != reconnects:
                    reconnects = ft.stats.reconnects
                    rec.write_event(name, "reconnect", float(reconnects))
                if status is not None and (last_status < 0 or seconds - last_status >= 0.25):
                    last_status = seconds
                    status(_status_line(seconds, rec, ft, name, audio))

            elapsed = run_until(settings.duration, rec, tick)
            with contextlib.suppress(FingertipError):
                ft.stop()
            rec.write_event(name, "stop")
            if audio is not None:   # before the recorder closes: what it captured is recorded
                audio.stop()
            s = rec.close()
            fst = ft.stats
            error = None
            if rec.error is not None:
                error = (f"{rec.error}; what was written before is readable, and "
                         f"`fingertip repair {settings.output}` makes a complete copy of it")
            return FingertipSummary(
                output=settings.output, elapsed_s=elapsed,
                frames=s.written.get(f"/fingertip/{name}/raw", 0),
                forces=s.written.get(f"/fingertip/{name}/wrench", 0),
                audio_s=(s.audio_frames.get(name, 0) / audio.sample_rate) if audio else 0.0,
                audio_chunks=s.written.get(f"/fingertip/{name}/audio", 0),
                events=s.written.get(f"/fingertip/{name}/events", 0),
                dropped=s.dropped_total, megabytes=s.bytes_written / 1e6,
                frames_lost=fst.frames_lost, crc_errors=fst.crc_errors,
                reconnects=fst.reconnects, error=error, device_resets=fst.device_resets,
                outage_frames=fst.outage_frames, gone_s=ft.gone_s)
        finally:
            if audio is not None:
                audio.stop()
            if rec is not None:
                rec.close()
    finally:
        ft.close()
