"""A network session's stop condition: SIGTERM ends it, and the caller's handler is back after."""
from __future__ import annotations

import os
import signal

from fingertip.network.stopper import Stopper


def test_sigterm_stops_the_session_and_the_old_handler_returns():
    seen = []
    old = signal.signal(signal.SIGTERM, lambda *_: seen.append("caller"))
    try:
        with Stopper(None) as stopper:
            assert stopper.wait(0.01)
            os.kill(os.getpid(), signal.SIGTERM)
            assert not stopper.wait(1.0)
        assert seen == []
        os.kill(os.getpid(), signal.SIGTERM)
        assert seen == ["caller"]
    finally:
        signal.signal(signal.SIGTERM, old)


def test_duration_ends_the_session():
    with Stopper(0.05) as stopper:
        while stopper.wait(0.01):
            pass
        assert not stopper.event.is_set()
