"""A probe whose device falls behind while the check goes on, as a starved simulator does on
a busy host: after each guided step's capture the device is paused for ``pause_s`` of host
time, and the check asks for its next step ``ahead_s`` into that pause. The device is then
behind its pace when the step is asked, and catches up after."""
from __future__ import annotations

import threading
import time
from collections.abc import Callable
from contextlib import AbstractContextManager

from fingertip.check.probe import DeviceProbe


class LaggingProbe(DeviceProbe):
    def __init__(self, ft, pause: Callable[[], AbstractContextManager], pause_s: float,
                 ahead_s: float) -> None:
        super().__init__(ft)
        self.pause, self.pause_s, self.ahead_s = pause, pause_s, ahead_s
        self.lags = 0

    def capture(self, seconds: float, **kw):
        seg = super().capture(seconds, **kw)
        if kw.get("since") is not None or kw.get("since_device_s") is not None:
            paused = threading.Event()

            def hold() -> None:
                with self.pause():
                    paused.set()
                    time.sleep(self.pause_s)

            threading.Thread(target=hold, daemon=True).start()
            paused.wait()
            time.sleep(self.ahead_s)  # the check's own work meanwhile
            self.lags += 1
        return seg
