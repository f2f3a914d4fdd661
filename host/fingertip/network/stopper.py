"""When a network session (``publish``, ``record --from``) stops: Ctrl-C, SIGTERM or the
end of ``--duration``."""
from __future__ import annotations

import signal
import threading
import time


class Stopper:
    """Ctrl-C, SIGTERM or the end of --duration."""

    def __init__(self, duration: float | None) -> None:
        self.event = threading.Event()
        self.t_end = time.monotonic() + duration if duration else None
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGTERM, lambda *_: self.event.set())

    def wait(self, step: float = 0.1) -> bool:
        """Sleep a step; False once it is time to stop."""
        try:
            left = step if self.t_end is None else min(step, self.t_end - time.monotonic())
            if left <= 0:
                return False
            return not self.event.wait(left)
        except KeyboardInterrupt:
            return False
