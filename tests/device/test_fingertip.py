"""The Fingertip's life cycle and frame path against the virtual device on a real pty,
through pyserial (its commands, link and restore have test files of their own)."""
from __future__ import annotations

import numpy as np

from fingertip import Fingertip

from .waiting import PATIENCE, wait_for


def test_open_info_tare_stream(device):
    with Fingertip(str(device.link)) as ft:
        assert ft.status == "connected"
        assert ft.info.channels == 4 and ft.info.protocol_major == 1
        assert ft.ping() < 0.5
        offsets = ft.tare(samples=8)
        assert offsets[1] == -50_000 and 1000 <= offsets[0] <= 1006
        ft.start()
        frames = [f for _, f in zip(range(40), ft.frames(timeout=1.0), strict=False)]
        assert len(frames) == 40
        seqs = [f.seq for f in frames]
        assert seqs == sorted(seqs)
        assert all(f.counts[1] == 0 and f.counts[3] == 0 for f in frames)
        assert all(f.saturation_mask == 0b0100 and not f.valid(2) for f in frames)
        dts = [b.device_time_us - a.device_time_us for a, b in zip(frames, frames[1:],
                                                                  strict=False)]
        assert set(dts) <= {12_500, 12_496, 12_504}
        # Host times are mapped device times, in the right place (their accuracy under
        # jitter and drift is measured in test_timesync; this machine may be loaded).
        # A mapped time is never after the frame arrived (the map is the arrivals' lower
        # envelope), and most frames arrive soon after it; beside busy loops some a
        # scheduler's slice or more later.
        late = np.array([f.arrival_time - f.host_time for f in frames[10:]])
        assert late.min() > -1e-3 and np.median(late) < 0.1
        assert all(b.host_time > a.host_time for a, b in zip(frames, frames[1:], strict=False))
        st = ft.stats
        assert st.frames_ok >= 40 and st.crc_errors == 0 and st.frames_lost == 0
        dev_stats = ft.device_stats()
        assert dev_stats.frames_sent > 40
        ft.stop()





def test_callbacks_and_overrun_counting(device):
    got = []
    with Fingertip(str(device.link), queue_size=5) as ft:
        ft.add_callback(got.append)
        ft.add_callback(lambda f: 1 / 0)  # a broken callback is counted, not fatal
        ft.start()
        assert wait_for(lambda: len(got) >= 20, PATIENCE)
        assert ft.stats.overruns >= 10 and ft.stats.callback_errors >= 20
        assert len(ft.drain()) == 5
