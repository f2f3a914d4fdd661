"""A live plot of the frame stream: a window that scrolls (``stream --plot``), or a PNG that
is rewritten every second (``stream --plot-png FILE``) on machines without a screen."""
from __future__ import annotations

import os
import time
from collections import deque
from pathlib import Path

import numpy as np


class NoDisplay(RuntimeError):
    """A window was asked for where there is no screen."""


class LivePlot:
    """Rolling traces of every channel over the last ``window_s`` seconds."""

    def __init__(self, channels: int, *, window_s: float = 10.0, png: str | Path | None = None,
                 refresh_s: float | None = None, labels: list[str] | None = None,
                 ylabel: str = "counts") -> None:
        import matplotlib

        self.png = Path(png) if png else None
        if self.png is None:
            if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
                raise NoDisplay("no screen here (DISPLAY is not set): use --plot-png FILE to "
                                "write the live plot to a PNG instead")
        else:
            matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        self.plt = plt
        self.window_s = window_s
        self.refresh_s = refresh_s if refresh_s is not None else (1.0 if self.png else 0.1)
        self.t: deque[float] = deque()
        self.v: deque[tuple[int, ...]] = deque()
        self.fig, self.ax = plt.subplots(figsize=(9, 4))
        names = labels or [f"channel {c}" for c in range(channels)]
        self.min_pad = 1.0 if ylabel == "counts" else 0.05
        self.lines = [self.ax.plot([], [], lw=1, label=names[c])[0] for c in range(channels)]
        self.ax.set_xlabel("time (s)")
        self.ax.set_ylabel(ylabel)
        self.ax.legend(loc="upper left", fontsize=8)
        self._last = 0.0
        if self.png is None:
            plt.ion()
            plt.show(block=False)

    def add(self, t: float, counts: tuple[float, ...]) -> None:
        self.t.append(t)
        self.v.append(counts)
        while self.t and self.t[0] < t - self.window_s:
            self.t.popleft()
            self.v.popleft()
        now = time.monotonic()
        if now - self._last >= self.refresh_s:
            self._last = now
            self.draw()

    def draw(self) -> None:
        if not self.t:
            return
        t = np.fromiter(self.t, float)
        v = np.array(self.v, dtype=float)
        for c, line in enumerate(self.lines):
            line.set_data(t, v[:, c])
        self.ax.set_xlim(max(t[0], t[-1] - self.window_s), t[-1] + 1e-3)
        if not np.isfinite(v).any():
            return
        lo, hi = float(np.nanmin(v)), float(np.nanmax(v))
        pad = max(self.min_pad, 0.05 * (hi - lo))
        self.ax.set_ylim(lo - pad, hi + pad)
        if self.png is not None:
            from ..outputs import atomic_output

            with atomic_output(self.png) as tmp:  # readers never see half a file
                self.fig.savefig(tmp, dpi=90, format="png")
        else:
            self.fig.canvas.draw_idle()
            self.plt.pause(0.001)

    def close(self) -> None:
        self.draw()
        self.plt.close(self.fig)
