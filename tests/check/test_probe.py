"""DeviceProbe.capture on a scripted stream of frames: which frames belong to an action.

The stand-in device below hands out frames as a late host's reader would: all at once, long
after they were made. The probe only calls ``drain()`` and ``read()`` during a capture."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from fingertip.check.probe import DeviceProbe
from fingertip.device import Frame

PERIOD_S = 0.0125
SINCE = 100.0
"""Host time (``time.monotonic()``) at which the action was asked."""


class ScriptedDevice:
    """``drain()`` returns what the reader had queued; ``read()`` the frames after it."""

    channels = 4

    def __init__(self, queued: list[Frame], later: list[Frame]) -> None:
        self.info = SimpleNamespace(tare_offsets=(0,) * 4, rate_sps=80, decimation=1, gain=128)
        self._queued, self._later = list(queued), list(later)

    def drain(self) -> list[Frame]:
        out, self._queued = self._queued, []
        return out

    def read(self, timeout: float | None = None) -> Frame | None:
        return self._later.pop(0) if self._later else None


def frames(first: int, n: int, arrival: float, jump_at: int | None = None) -> list[Frame]:
    """Frames ``first`` .. ``first + n - 1``: made at ``SINCE + (k - 100) * PERIOD_S`` of host
    time (device time = host time - 90 s), all arriving at ``arrival``; from frame
    ``jump_at`` on, channel 0 reads 10000 counts more (the action)."""
    out = []
    for k in range(first, first + n):
        made = SINCE + (k - 100) * PERIOD_S
        c0 = 10000 if jump_at is not None and k >= jump_at else 0
        out.append(Frame(k, int(round((made - 90.0) * 1e6)), made, max(made, arrival),
                         (c0, 0, 0, 0)))
    return out


def test_a_capture_starts_at_the_first_frame_made_after_it_was_asked():
    # The reader was 1.25 s behind: frames 0-99, made in the second before the action was
    # asked, arrive with the first ones made after it (all at SINCE + 0.25 s).
    late = SINCE + 0.25
    stream = frames(0, 160, late, jump_at=130)
    probe = DeviceProbe(ScriptedDevice(stream[:120], stream[120:]))
    seg = probe.capture(0.5, timeout=0.1, since=SINCE)
    assert seg.times_s[0] == stream[100].device_time_us * 1e-6
    assert seg.times_s[-1] - seg.times_s[0] >= 0.5
    # The action (frame 130) is inside the capture, 0.375 s after its start.
    assert np.count_nonzero(seg.counts[:, 0] == 10000) > 0
    assert probe.last_time_s == seg.times_s[-1]


def test_frames_made_before_it_was_asked_are_skipped_when_read_after_the_drain():
    # The queue was empty when the capture began: the stale frames come through read().
    stream = frames(0, 160, SINCE + 0.5, jump_at=130)
    probe = DeviceProbe(ScriptedDevice([], stream))
    seg = probe.capture(0.5, timeout=0.1, since=SINCE)
    assert seg.times_s[0] == stream[100].device_time_us * 1e-6


def test_frames_queued_on_time_and_made_after_it_was_asked_count():
    # A host that was away but whose reader kept up: the action's frames were queued when
    # the capture began, each arrived as it was made.
    stream = frames(90, 70, 0.0, jump_at=105)
    probe = DeviceProbe(ScriptedDevice(stream[:30], stream[30:]))
    seg = probe.capture(0.5, timeout=0.1, since=SINCE)
    assert seg.times_s[0] == stream[10].device_time_us * 1e-6
    assert seg.counts[5, 0] == 10000


def test_without_since_a_capture_is_what_comes_next():
    stream = frames(0, 100, 0.0)
    probe = DeviceProbe(ScriptedDevice(stream[:50], stream[50:]))
    seg = probe.capture(0.25, timeout=0.1)
    assert seg.times_s[0] == stream[50].device_time_us * 1e-6
    assert len(seg) == 21


def test_frames_with_no_clock_map_yet_use_their_arrival():
    made = [Frame(k, k * 12500, float("nan"), SINCE - 1 + k * PERIOD_S, (0, 0, 0, 0))
            for k in range(160)]
    probe = DeviceProbe(ScriptedDevice(made[:100], made[100:]))
    seg = probe.capture(0.25, timeout=0.1, since=SINCE)
    assert seg.times_s[0] == made[80].device_time_us * 1e-6


def test_a_capture_from_a_device_time_takes_what_a_lagging_simulator_made_after_it():
    # A simulator 0.375 s behind its pace: asked at host time SINCE + 0.375 s, when its own
    # clock read frame 100's stamp, it steps the load at frame 110. Each frame's mapped host
    # time is where it would have been made on pace, so frames 100-129 map before the
    # request: by host time the capture begins at frame 130 and misses the step.
    stream = frames(0, 160, SINCE + 0.5, jump_at=110)
    asked_host, asked_device = SINCE + 0.375, stream[100].device_time_us * 1e-6
    seg = DeviceProbe(ScriptedDevice(stream[:120], stream[120:])).capture(
        0.25, timeout=0.1, since=asked_host)
    assert seg.times_s[0] == stream[130].device_time_us * 1e-6
    assert np.all(seg.counts[:, 0] == 10000)  # no step in it
    seg = DeviceProbe(ScriptedDevice(stream[:120], stream[120:])).capture(
        0.25, timeout=0.1, since_device_s=asked_device)
    assert seg.times_s[0] == asked_device
    assert seg.counts[9, 0] == 0 and seg.counts[10, 0] == 10000


def test_one_start_only():
    probe = DeviceProbe(ScriptedDevice([], []))
    with pytest.raises(ValueError, match="not both"):
        probe.capture(0.1, since=SINCE, since_device_s=1.0)
