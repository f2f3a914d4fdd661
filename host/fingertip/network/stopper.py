"""When a network session (``publish``, ``record --from``) stops: Ctrl-C, SIGTERM or the
end of ``--duration``."""
from __future__ import annotations

import contextlib
import threading
import time

from ..record.session import sigterm_sets


class Stopper(contextlib.AbstractContextManager):
    """Ctrl-C, SIGTERM or the end of --duration. Use it as a context manager: inside, SIGTERM
    ends the session (:func:`~fingertip.record.session.sigterm_sets`), and the previous
    handler is back once the session returns."""

    def __init__(self, duration: float | None) -> None:
        self.event = threading.Event()
        self.t_end = time.monotonic() + duration if duration else None
        self._sigterm = sigterm_sets(self.event)

    def __enter__(self) -> Stopper:
        self._sigterm.__enter__()
        return self

    def __exit__(self, *exc: object) -> None:
        self._sigterm.__exit__(*exc)

    def wait(self, step: float = 0.1) -> bool:
        """Sleep a step; False once it is time to stop."""
        try:
            left = step if self.t_end is None else min(step, self.t_end - time.monotonic())
            if left <= 0:
                return False
            return not self.event.wait(left)
        except KeyboardInterrupt:
            return False
