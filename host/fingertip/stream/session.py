"""One stream session (``fingertip stream --port P``): a fingertip's frames, as lines or JSON
objects, or a live line that rewrites itself, with forces from a calibration and a live plot
when asked; until a count of frames, a duration or Ctrl-C, then its counters.

:func:`stream_fingertip` opens the device, sets it up, streams and returns a
:class:`StreamSummary`. What the session shows goes through callbacks, so that the command
line decides where it is printed. A user error found before streaming (no screen for a
plot, a force model refused for this device) is a :class:`StreamError`; the device's errors
are raised as they are. A hand is streamed by :func:`fingertip.stream.hand.stream_hand`.
"""
from __future__ import annotations

import contextlib
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from ..device import Fingertip, FingertipError
from ..errors import BadArgumentError
from ..device.health import link_text
from .text import force_fields, force_text, frame_json, frame_line

Say = Callable[[str], None]


class StreamError(BadArgumentError):
    """A user error found before streaming (no screen, a refused force model): one line, a
    :class:`~fingertip.errors.BadArgumentError` (exit status 2)."""


@dataclass(frozen=True)
class StreamSettings:
    """What to stream and how (the ``stream`` command's options)."""

    count: int | None = None        # stop after this many frames
    duration: float | None = None   # seconds; None (and no count): until Ctrl-C
    json: bool = False              # one JSON object per frame
    rate: int | None = None         # the chips' rate (10 or 80 SPS)
    decimation: int | None = None
    gain: int | None = None
    tare: int | None = None         # samples to tare with first
    plot: bool = False              # a live plot in a window
    plot_png: str | None = None     # a live plot rewritten into this PNG every second
    force_model: str | None = None  # FORCE.onnx: forces in newtons

    @property
    def plotting(self) -> bool:
        return self.plot or bool(self.plot_png)

    def apply(self, dev: Fingertip) -> None:
        """Set rate and decimation, and gain, on a device before it starts (one fingertip,
        or each device of a hand)."""
        if self.rate or self.decimation:
            dev.set_rate(self.rate or dev.info.rate_sps, self.decimation or 1)
        if self.gain:
            dev.set_gain(self.gain)

    def until(self) -> Callable[[int], bool]:
        """``more(n)``: whether to go on after ``n`` frames (the count, the duration)."""
        t_end = (time.monotonic() + self.duration) if self.duration else None
        return lambda n: ((self.count is None or n < self.count)
                          and (t_end is None or time.monotonic() < t_end))


@dataclass(frozen=True)
class StreamSummary:
    """The frames one session showed, and the device's loss counters."""

    frames: int
    frames_lost: int
    crc_errors: int
    cobs_errors: int
    reconnects: int
    device_resets: int
    outage_frames: int = 0
    """Of ``frames_lost``, those missing across outages (link lost and back, a restart)."""

    def text(self) -> str:
        return f"{self.frames} frames; {link_text(self)}, COBS errors {self.cobs_errors}"


def _plot(channels: int, settings: StreamSettings, force: bool = False):
    from .plot import LivePlot, NoDisplay

    try:
        if force:
            return LivePlot(2, png=settings.plot_png, labels=["Fx", "Fy"],
                            ylabel="force (N)")
        return LivePlot(channels, png=settings.plot_png)
    except NoDisplay as e:
        raise StreamError(str(e)) from e


def _force_model(ft: Fingertip, path: str):
    from ..models.force.force_load import ModelMismatch, force_model_for

    try:
        return force_model_for(ft, path)
    except (ModelMismatch, FileNotFoundError, ValueError) as e:
        raise StreamError(f"--force-model refused: {e}") from e


def stream_fingertip(settings: StreamSettings, *, port: str | None = None,
                     serial: str | None = None, out: Say, live: Say | None = None,
                     waiting: Say | None = None) -> StreamSummary:
    """Stream the fingertip on ``port`` (or with USB ``serial``) until the settings' count or
    duration, or Ctrl-C.

    ``out`` gets one line per frame (JSON with ``settings.json``). With ``live`` (and no
    JSON) it gets instead, at most every 0.1 s, a status line meant to replace the one
    before. ``waiting`` gets the device's status while no frame comes and it is not
    connected. The device is closed whatever happens.
    """
    # A window asked for where there is no screen is refused before the port is opened;
    # the plot is made again once the channels (and the force model) are known.
    plot = _plot(4, settings) if settings.plotting else None
    try:
        with (Fingertip(serial_number=serial) if serial else Fingertip(port)).open() as ft:
            fm = _force_model(ft, settings.force_model) if settings.force_model else None
            if fm is not None and plot is not None:
                plot.close()
                plot = _plot(2, settings, force=True)
            elif plot is not None and len(plot.lines) != ft.channels:
                plot.close()
                plot = _plot(ft.channels, settings)
            settings.apply(ft)
            if settings.tare:
                ft.tare(samples=settings.tare)
            ft.start()
            try:
                n = _loop(ft, settings, fm, plot, out, live if not settings.json else None,
                          waiting)
            finally:
                if plot is not None:
                    plot.close()
                    plot = None
                with contextlib.suppress(FingertipError):
                    ft.stop()
            st = ft.stats
            return StreamSummary(n, st.frames_lost, st.crc_errors, st.cobs_errors,
                                 st.reconnects, st.device_resets, st.outage_frames)
    finally:
        if plot is not None:
            plot.close()


def _loop(ft: Fingertip, settings: StreamSettings, fm: Any, plot: Any, out: Say,
          live: Say | None, waiting: Say | None) -> int:
    """Show frames until the settings say stop, or Ctrl-C; the number shown."""
    more = settings.until()
    n, last_print, first = 0, 0.0, None
    try:
        while more(n):
            f = ft.read(timeout=1.0)
            if f is None:
                if ft.status != "connected" and waiting is not None:
                    waiting(ft.status)
                continue
            n += 1
            first = first or f
            est = fm.estimate_frame(f) if fm is not None else None
            if plot is not None:
                plot.add((f.device_time_us - first.device_time_us) / 1e6,
                         f.counts if est is None else (est.fx, est.fy))
            force = "" if est is None else force_text(est)
            if settings.json:
                out(frame_json(f, **force_fields(est)))
            elif live is None:
                out(frame_line(f) + force)
            elif f.arrival_time - last_print > 0.1:
                last_print = f.arrival_time
                span = (f.device_time_us - first.device_time_us) / 1e6
                rate = (n - 1) / span if span > 0 else 0.0
                st = ft.stats
                live(f"{n:7d} frames {rate:6.1f}/s  " + " ".join(f"{c:9d}" for c in f.counts)
                     + force + f"  lost {st.frames_lost} crc {st.crc_errors}   ")
    except KeyboardInterrupt:
        pass
    return n
