"""How a device's link is doing, in words: the counters a session's summary prints, and the
warning repeated while a device stays away (a device that never comes back is reported
with how long it has been gone, not left as one WARNING at the moment it went)."""
from __future__ import annotations

import logging
from typing import Any

log = logging.getLogger(__name__)

GONE_EVERY_S = 5.0
"""Seconds between two reports of a device that is still away."""


def link_text(stats: Any) -> str:
    """``lost N (M across outages), CRC errors C, reconnects R, device resets K`` of a
    :class:`~fingertip.device.BridgeStats` (or of sums of them)."""
    outage = getattr(stats, "outage_frames", 0)
    return (f"lost {stats.frames_lost}" + (f" ({outage} across outages)" if outage else "")
            + f", CRC errors {stats.crc_errors}, reconnects {stats.reconnects}, device "
              f"resets {stats.device_resets}")


def gone_text(name: str, gone_s: float | None) -> str:
    """``; NAME gone for the last S s`` when a device is away at the end, else ``""``."""
    return "" if gone_s is None else f"; {name} gone for the last {gone_s:.1f} s"


class GoneReporter:
    """Call :meth:`check` often (a session's tick): logs a warning when a device has been
    gone for :data:`GONE_EVERY_S`, and again every as many seconds, until it is back."""

    def __init__(self, every_s: float = GONE_EVERY_S) -> None:
        self.every_s = every_s
        self._next: dict[str, float] = {}

    def check(self, name: str, gone_s: float | None, where: str = "") -> None:
        if gone_s is None:
            if self._next.pop(name, None) is not None:
                log.info("%s is back", name)
            return
        due = self._next.setdefault(name, self.every_s)
        if gone_s >= due:
            self._next[name] = (gone_s // self.every_s + 1) * self.every_s
            log.warning("%s: gone for %.0f s, still trying to reconnect%s", name, gone_s,
                        f" on {where}" if where else "")
