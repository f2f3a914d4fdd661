"""The recording session's library parts: the SIGTERM stop shared by a fingertip's and a
hand's session, the wait loop, and the output checks made before a device opens."""
from __future__ import annotations

import os
import signal
import threading
import time
from types import SimpleNamespace

import pytest

from fingertip.record.session import SessionError, check_output, run_until, sigterm_sets


def test_sigterm_sets_the_event_inside_and_restores_the_handler_after():
    mine = signal.signal(signal.SIGTERM, signal.SIG_DFL)  # whatever pytest had
    try:
        def before(*_):
            raise AssertionError("the old handler must not run inside")

        signal.signal(signal.SIGTERM, before)
        stop = threading.Event()
        with sigterm_sets(stop):
            os.kill(os.getpid(), signal.SIGTERM)
            assert stop.wait(2.0)
        assert signal.getsignal(signal.SIGTERM) is before
    finally:
        signal.signal(signal.SIGTERM, mine)


@pytest.mark.realtime
def test_run_until_stops_on_sigterm_and_on_a_failed_recorder():
    rec = SimpleNamespace(failed=False)
    timer = threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGTERM))
    timer.start()
    t0 = time.monotonic()
    elapsed = run_until(None, rec)
    assert 0.25 <= elapsed < 5 and time.monotonic() - t0 < 5
    ticks = []

    def tick(s: float) -> None:
        ticks.append(s)
        if len(ticks) == 3:
            rec.failed = True

    assert run_until(60.0, rec, tick) < 5 and len(ticks) == 3
    rec.failed = False
    assert 0.2 <= run_until(0.2, rec) < 2


def test_the_output_is_refused_before_a_device_opens(tmp_path):
    with pytest.raises(SessionError, match="is a directory"):
        check_output(tmp_path, overwrite=False)
    f = tmp_path / "run.mcap"
    f.write_bytes(b"x")
    with pytest.raises(SessionError, match="already exists"):
        check_output(f, overwrite=False)
    check_output(f, overwrite=True)
    check_output(tmp_path / "new.mcap", overwrite=False)
