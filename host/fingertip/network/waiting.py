"""Silence on the network, said out loud: which fingertips a subscriber has heard nothing
from, for how long, and when to give up. Pure: the caller passes the clock.

``record --from`` with no publisher used to say "recording..." once and then nothing, for
ever. :class:`Silence` makes it say what it waits for every few seconds and, with a limit,
end with one line.
"""
from __future__ import annotations

from collections.abc import Iterable

EVERY_S = 5.0
"""Seconds of silence between two "waiting for" lines."""

HINTS = {
    "dds": "is `fingertip publish` running, with the same ROS_DOMAIN_ID and discovery "
           "range?",
    "zenoh": "is `fingertip publish --transport zenoh` running and reachable (--zenoh-connect "
             "or --zenoh-listen)?",
    "lsl": "is `fingertip publish --transport lsl` running on this network?",
}


class Silence:
    """Time since each fingertip was last heard from (from ``start`` until its first
    message). :meth:`heard` on every message, :meth:`check` often."""

    def __init__(self, names: Iterable[str], source: str, start: float, *,
                 every_s: float = EVERY_S, timeout_s: float | None = None) -> None:
        if not every_s > 0:
            raise ValueError(f"every_s must be positive, not {every_s!r}")
        if timeout_s is not None and not timeout_s > 0:
            raise ValueError(f"the wait timeout must be a positive number of seconds, not "
                             f"{timeout_s!r}")
        self.source = source
        self.every_s = every_s
        self.timeout_s = timeout_s
        self.last: dict[str, float] = dict.fromkeys(names, start)
        self.ever: set[str] = set()
        self._said: dict[str, int] = dict.fromkeys(self.last, 0)

    def heard(self, name: str, now: float) -> None:
        if name in self.last:
            self.last[name] = now
            self.ever.add(name)

    def check(self, now: float) -> tuple[list[str], str | None]:
        """``(lines to say now, the line to end with or None)``: a line per fingertip each
        ``every_s`` of its silence, and the end once one has been silent ``timeout_s``."""
        lines: list[str] = []
        for name, t in self.last.items():
            quiet = now - t
            if self.timeout_s is not None and quiet >= self.timeout_s:
                return lines, self._line(name, quiet, ended=True)
            n = int(quiet // self.every_s)
            if n > self._said[name]:
                lines.append(self._line(name, quiet, ended=False))
            self._said[name] = n
        return lines, None

    def _line(self, name: str, quiet: float, ended: bool) -> str:
        what = ("nothing received yet" if name not in self.ever
                else "nothing received since the last message")
        if ended:
            return (f"no messages from {name} over {self.source} for {quiet:.0f} s "
                    f"(--wait-timeout {self.timeout_s:g}): {HINTS.get(self.source, '')}")
        return (f"waiting for {name} over {self.source}: {what} for {quiet:.0f} s; "
                f"{HINTS.get(self.source, '')}")
