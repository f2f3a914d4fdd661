"""A published or recorded hand is read like published single fingertips: every device of the
process on one shared reader thread, and no queue (of the devices or the hand) that counts
overruns of frames nobody reads."""
from __future__ import annotations

import contextlib
import threading

import pytest

from fingertip.device import FingertipError
from fingertip.hand_args import HandSpec, parse_split
from fingertip.network.hand import open_fingers
from fingertip.sim import VirtualFirmware
from fingertip.sim.device.pty_device import PtyDevice
from tests.device.waiting import PATIENCE, wait_for

FINGERS = ("index", "middle", "ring")


def _reader_threads() -> list[str]:
    return sorted(t.name for t in threading.enumerate()
                  if t.name.startswith("fingertip-reader"))


def _stream(views, n: int) -> dict[str, list]:
    got: dict[str, list] = {v.name: [] for v in views}
    for v in views:
        v.add_callback(got[v.name].append)
    for v in views:
        v.start()
    assert wait_for(lambda: all(len(g) >= n for g in got.values()), PATIENCE)
    return got


def test_a_hand_of_devices_is_read_on_one_thread_without_queues(tmp_path):
    devs = [PtyDevice(VirtualFirmware(4, source=lambda t, k=k: (k + 1,) * 4),
                      link=tmp_path / f).start() for k, f in enumerate(FINGERS)]
    try:
        spec = HandSpec(ports={f: str(tmp_path / f) for f in FINGERS})
        with contextlib.ExitStack() as stack:
            views = open_fingers(spec, stack)
            got = _stream(views, 40)
            # One thread for the three devices (one each before: fingertip-reader-<finger>).
            assert _reader_threads() == ["fingertip-reader-shared"]
            for k, v in enumerate(views):
                seqs = [f.seq for f in got[v.name]]
                assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))  # none lost
                assert all(f.counts == (k + 1,) * 4 for f in got[v.name])
                assert v.stats.overruns == 0 and v.stats.callback_errors == 0
                with pytest.raises(FingertipError, match="queue_size=0"):
                    v.device.read(0.1)  # the device queues nothing ...
            with pytest.raises(FingertipError, match="queue_size=0"):
                views[0].hand.read(0.1)  # ... and neither does the hand
            assert views[0].hand.overruns == 0
        assert wait_for(lambda: not _reader_threads(), PATIENCE)  # ends with the hand
    finally:
        for d in devs:
            d.stop()


def test_a_split_device_is_read_on_the_shared_thread_too(tmp_path):
    with PtyDevice(VirtualFirmware(16, source=lambda t: tuple(range(16))),
                   link=tmp_path / "hand") as dev:
        spec = HandSpec(groups=parse_split("4x4"), port=str(dev.link))
        with contextlib.ExitStack() as stack:
            views = open_fingers(spec, stack)
            got = _stream(views, 20)
            assert _reader_threads() == ["fingertip-reader-shared"]
            for k, v in enumerate(views):
                assert got[v.name][-1].counts == tuple(range(4 * k, 4 * k + 4))
            with pytest.raises(FingertipError, match="queue_size=0"):
                views[0].hand.read(0.1)


def test_a_recorded_hand_is_read_on_one_thread_without_queues(tmp_path):
    """`record --hand`: the recorder takes frames by callback, so the hand and its devices
    queue nothing (no phantom overruns), one thread reads them, and the summary gives the
    devices' own loss counters."""
    from fingertip.record.hand_record import record_hand
    from fingertip.record.reader import Recording
    from fingertip.record.session import RecordSettings

    devs = [PtyDevice(VirtualFirmware(4, source=lambda t, k=k: (k + 1,) * 4),
                      link=tmp_path / f).start() for k, f in enumerate(FINGERS)]
    seen: list[list[str]] = []
    try:
        spec = HandSpec(ports={f: str(tmp_path / f) for f in FINGERS})
        out = tmp_path / "hand.mcap"
        res = record_hand(RecordSettings(out, duration=1.0), spec, [],
                          say=lambda line: seen.append(_reader_threads()))
        assert seen == [["fingertip-reader-shared"]]
        assert res.error is None and res.dropped == 0
        assert (res.frames_lost, res.crc_errors, res.reconnects) == (0, 0, 0)
        assert "devices: lost 0, CRC errors 0, reconnects 0" in res.text()
        assert all(c["raw"] >= 40 for c in res.per_finger.values()), res.per_finger
        assert Recording(out).devices() == sorted(FINGERS)
        assert wait_for(lambda: not _reader_threads(), PATIENCE)
    finally:
        for d in devs:
            d.stop()
