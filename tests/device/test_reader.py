"""Several fingertips read on one SharedReader thread, and queue-less (callback-only)
fingertips, against virtual devices on real ptys."""
from __future__ import annotations

import os
import threading

import pytest

from fingertip import Fingertip
from fingertip.device import FingertipError, SharedReader
from fingertip.device.reader import SharedDevice
from fingertip.sim import VirtualFirmware
from fingertip.sim.device.pty_device import PtyDevice
from fingertip.transport import TransportError

from .waiting import PATIENCE, wait_for



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
        assert wait_for(lambda: len(got[0]) >= 60 and len(got[1]) >= 60, PATIENCE)
        assert _reader_threads() == ["fingertip-reader-shared"]
        for k, ft in enumerate((a, b)):
            seqs = [f.seq for f in got[k]]
            assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))  # none lost, in order
            assert all(f.counts[0] == 1000 * (k + 1) for f in got[k])
            st = ft.stats
            assert st.frames_lost == 0 and st.overruns == 0 and st.callback_errors == 0
        assert reader.wakeups > 0
    assert wait_for(lambda: not _reader_threads(), PATIENCE)  # the thread ends with its devices
    reader.close()


def test_queue_less_fingertip_counts_no_overruns_and_refuses_reads(devices):
    got = []
    with Fingertip(str(devices[0].link), queue_size=0) as ft:
        ft.add_callback(got.append)
        ft.start()
        # More frames than any queue of 1 would hold: nothing is lost, nothing counted.
        assert wait_for(lambda: len(got) >= 30, PATIENCE)
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
        assert wait_for(lambda: len(got) >= 5, PATIENCE)
        devices[0].unplug()
        assert wait_for(lambda: a.status == "reconnecting", PATIENCE)
        n_b = len(seen_b)
        assert wait_for(lambda: len(seen_b) >= n_b + 10, PATIENCE)  # b goes on meanwhile
        devices[0].replug(reboot=True)
        assert wait_for(lambda: a.status == "connected", PATIENCE)
        n = len(got)
        assert wait_for(lambda: len(got) >= n + 10, PATIENCE)  # streaming again (set-up restored)
        assert a.stats.reconnects == 1
        assert wait_for(lambda: _reader_threads() == ["fingertip-reader-shared"], PATIENCE)
    reader.close()


class PipeDevice:
    """Any device that offers :class:`SharedDevice` is read by the shared thread (here the
    read end of a real pipe; nothing of a Fingertip)."""

    def __init__(self) -> None:
        self.r, self.w = os.pipe()
        os.set_blocking(self.r, False)
        self.got = bytearray()
        self.failed: list[Exception] = []
        self.own_reader_started = threading.Event()
        self.fail_next = False
        self.needs_own_reader = False

    def read_available(self) -> None:
        if self.fail_next:
            raise TransportError("the pipe went away")
        self.got += os.read(self.r, 4096)

    def read_failed(self, error: TransportError) -> None:
        self.failed.append(error)

    def start_own_reader(self) -> None:
        self.own_reader_started.set()


def test_the_shared_reader_needs_only_the_shared_device_protocol():
    reader = SharedReader()
    dev, lost, verdict = PipeDevice(), PipeDevice(), PipeDevice()
    device: SharedDevice = dev  # what a type checker accepts, the reader takes
    try:
        for d in (device, lost, verdict):
            reader.add(d, d.r)
        os.write(dev.w, b"abc")
        assert wait_for(lambda: bytes(dev.got) == b"abc", PATIENCE)
        lost.fail_next = True
        os.write(lost.w, b"x")  # readable, and reading it fails: dropped, told, not retried
        assert wait_for(lambda: len(lost.failed) == 1, PATIENCE)
        verdict.needs_own_reader = True  # dropped and handed back to its own thread
        assert verdict.own_reader_started.wait(2.0)
        os.write(dev.w, b"def")
        assert wait_for(lambda: bytes(dev.got) == b"abcdef", PATIENCE)
        assert len(lost.failed) == 1 and reader.wakeups >= 2
        reader.remove(dev)
        assert wait_for(lambda: not _reader_threads(), PATIENCE)  # no member left: the thread ends
    finally:
        reader.close()
        for d in (dev, lost, verdict):
            os.close(d.r)
            os.close(d.w)
