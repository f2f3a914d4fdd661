"""Several fingertips read on one SharedReader thread, and queue-less (callback-only)
fingertips, against virtual devices on real ptys."""
from __future__ import annotations

import threading

import pytest

from fingertip import Fingertip
from fingertip.device import FingertipError, SharedReader
from fingertip.sim import VirtualFirmware
from fingertip.sim.device.pty_device import PtyDevice

from .test_fingertip_pty import wait_for


def _fw(k: int) -> VirtualFirmware:
    return VirtualFirmware(4, source=lambda t, k=k: (1000 * k, 2, 3, 4))


@pytest.fixture
def devices(tmp_path):
    with PtyDevice(_fw(1), link=tmp_path / "a") as a, PtyDevice(_fw(2), link=tmp_path / "b") as b:
        yield a, b


def _reader_threads() -> list[str]:
    return [t.name for t in threading.enumerate() if t.name.startswith("fingertip-reader")]


def test_two_devices_on_one_thread_every_frame_in_order(devices):
    reader = SharedReader()
    got: dict[int, list] = {0: [], 1: []}
    with Fingertip(str(devices[0].link), queue_size=0, reader=reader) as a, \
            Fingertip(str(devices[1].link), queue_size=0, reader=reader) as b:
        for k, ft in enumerate((a, b)):
            ft.add_callback(got[k].append)
        assert a.ping() < 0.5 and b.ping() < 0.5  # commands answered through the shared thread
        a.start()
        b.start()
        assert wait_for(lambda: len(got[0]) >= 60 and len(got[1]) >= 60, 5.0)
        assert _reader_threads() == ["fingertip-reader-shared"]
        for k, ft in enumerate((a, b)):
            seqs = [f.seq for f in got[k]]
            assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))  # none lost, in order
            assert all(f.counts[0] == 1000 * (k + 1) for f in got[k])
            st = ft.stats
            assert st.frames_lost == 0 and st.overruns == 0 and st.callback_errors == 0
        assert reader.wakeups > 0
    assert wait_for(lambda: not _reader_threads(), 2.0)  # the thread ends with its devices
    reader.close()


def test_queue_less_fingertip_counts_no_overruns_and_refuses_reads(devices):
    got = []
    with Fingertip(str(devices[0].link), queue_size=0) as ft:
        ft.add_callback(got.append)
        ft.start()
        # More frames than any queue of 1 would hold: nothing is lost, nothing counted.
        assert wait_for(lambda: len(got) >= 30, 3.0)
        assert ft.stats.overruns == 0
        for use in (lambda: ft.read(0.1), ft.drain, lambda: next(ft.frames(0.1))):
            with pytest.raises(FingertipError, match="queue_size=0"):
                use()


def test_unplugged_device_reconnects_and_returns_to_the_shared_thread(devices):
    reader = SharedReader()
    got: list = []
    with Fingertip(str(devices[0].link), queue_size=0, reader=reader) as a, \
            Fingertip(str(devices[1].link), queue_size=0, reader=reader) as b:
        a.add_callback(got.append)
        seen_b: list = []
        b.add_callback(seen_b.append)
        a.start()
        b.start()
        assert wait_for(lambda: len(got) >= 5, 2.0)
        devices[0].unplug()
        assert wait_for(lambda: a.status == "reconnecting", 2.0)
        n_b = len(seen_b)
        assert wait_for(lambda: len(seen_b) >= n_b + 10, 2.0)  # b goes on meanwhile
        devices[0].replug(reboot=True)
        assert wait_for(lambda: a.status == "connected", 2.0)
        n = len(got)
        assert wait_for(lambda: len(got) >= n + 10, 3.0)  # streaming again (set-up restored)
        assert a.stats.reconnects == 1
        assert wait_for(lambda: _reader_threads() == ["fingertip-reader-shared"], 2.0)
    reader.close()
