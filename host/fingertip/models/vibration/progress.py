"""Progress of a long job on stderr: one bar per phase, never on stdout.

``fingertip train material`` prints its report on stdout (as JSON with ``--json``), so the
progress goes to stderr only. On a terminal a phase redraws one line in place; elsewhere
(a log file, CI) it writes a line when the phase starts and one when it ends, so a log
stays short. ``FINGERTIP_PROGRESS=0`` turns it off; a library caller passes
``progress=False``.
"""
from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable
from typing import TextIO

ENV = "FINGERTIP_PROGRESS"
REDRAW_S = 0.2
"""At most one redraw per this many seconds on a terminal."""


class Progress:
    """One phase's bar: ``with Progress("features", total) as p: p.update()``."""

    def __init__(self, what: str, total: int, *, enabled: bool = True,
                 stream: TextIO | None = None) -> None:
        self.what = what
        self.total = max(0, int(total))
        self.done = 0
        self.stream = sys.stderr if stream is None else stream
        self.enabled = enabled and os.environ.get(ENV, "1") != "0"
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self._t0 = time.perf_counter()
        self._drawn = 0.0

    def __enter__(self) -> Progress:
        if self.enabled and not self.tty:
            self._write(f"{self.what}: {self.total} steps ...\n")
        self._draw(force=True)
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def update(self, n: int = 1) -> None:
        self.done = min(self.total, self.done + n) if self.total else self.done + n
        self._draw()

    def close(self) -> None:
        if not self.enabled:
            return
        took = time.perf_counter() - self._t0
        if self.tty:
            self._draw(force=True)
            self._write("\n")
        else:
            self._write(f"{self.what}: {self.done}/{self.total} in {took:.1f} s\n")
        self.enabled = False

    def line(self) -> str:
        """The bar as drawn on a terminal."""
        width = 24
        frac = self.done / self.total if self.total else 1.0
        bar = "#" * int(round(frac * width))
        took = time.perf_counter() - self._t0
        return (f"{self.what:<28.28} [{bar:<{width}}] {self.done}/{self.total} "
                f"{took:6.1f} s")

    def _draw(self, force: bool = False) -> None:
        if not (self.enabled and self.tty):
            return
        now = time.perf_counter()
        if force or now - self._drawn >= REDRAW_S or self.done == self.total:
            self._drawn = now
            self._write("\r" + self.line())

    def _write(self, text: str) -> None:
        try:
            self.stream.write(text)
            self.stream.flush()
        except (OSError, ValueError):  # a closed or broken stderr must not stop the work
            self.enabled = False


class Bars:
    """One bar at a time: ``done = bars("phase", total)`` opens a bar (closing the last)
    and returns its step; :meth:`close` ends the last one."""

    def __init__(self, enabled: bool = True, stream: TextIO | None = None) -> None:
        self.enabled = enabled
        self.stream = stream
        self._bar: Progress | None = None

    def __call__(self, what: str, total: int) -> Callable[[], None]:
        self.close()
        self._bar = Progress(what, total, enabled=self.enabled, stream=self.stream)
        self._bar.__enter__()
        return self._bar.update

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None
