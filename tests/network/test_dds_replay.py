"""Publishing a recording with --sim-time: the recording's own messages (stamps included)
go out over DDS, and /clock follows them for subscribers with use_sim_time."""
from __future__ import annotations

import signal
import struct
import time

from fingertip.network.dds import SENSOR, DdsNode
from fingertip.network.ros_types import CLOCK
from fingertip.record import schemas as S

from .conftest import start, wait_line
from .test_dds_stream import FORCE_MODEL, by_topic, unpadded


def test_replay_with_sim_time_publishes_the_recording_and_clock(tmp_path):
    original, remote = tmp_path / "original.mcap", tmp_path / "remote.mcap"
    made = start("publish", "--virtual", "1", "--name", "index", "--virtual-audio",
                 "--force-model", FORCE_MODEL, "--duration", "3", "--record", str(original))
    _, err = made.communicate(timeout=60)
    assert made.returncode == 0, err
    clock: list[int] = []
    node = DdsNode()

    def on_clock(d: bytes) -> None:
        sec, nsec = struct.unpack_from("<iI", d, 4)
        clock.append(sec * S.NS + nsec)
    node.reader("rt/clock", CLOCK, SENSOR, on_clock, depth=1000)  # a busy test keeps all
    sub = start("record", "--from", "dds", "--name", "index", "-o", str(remote))
    try:
        wait_line(sub, "recording index from dds")
        pub = start("publish", "--replay", str(original), "--sim-time",
                    "--wait-subscribers", "1", "--speed", "2")
        _, err = pub.communicate(timeout=60)
        assert pub.returncode == 0, err
        time.sleep(0.5)
    finally:
        sub.send_signal(signal.SIGTERM)
        _, sub_err = sub.communicate(timeout=30)
        node.close()
    assert sub.returncode == 0, sub_err
    a, b = by_topic(original), by_topic(remote)
    for kind in ("raw", "wrench", "events"):
        t = S.topic("index", kind)
        assert len(b[t]) == len(a[t]) > 0, kind
        for (ta, da), (tb, db) in zip(a[t], b[t], strict=True):
            assert tb == ta and unpadded(db, da), kind  # the recording's own stamps
    # Audio: the replay re-chunks it; the samples and their first stamp are the recording's.
    au = S.topic("index", "audio")
    data_a = b"".join(S.decode_audio(d).data for _, d in a[au])
    data_b = b"".join(S.decode_audio(d).data for _, d in b[au])
    assert data_b == data_a and a[au][0][0] == b[au][0][0]
    raw_stamps = [S.decode_raw(d).stamp_ns for _, d in a[S.topic("index", "raw")]]
    # A tick per frame from when this reader matched the /clock writer (best effort: a few
    # may drop); on a busy host discovery can take the replay's first ticks.
    assert clock == sorted(clock) and set(clock) <= set(raw_stamps)
    assert clock[-1] == raw_stamps[-1]
    since_matched = [t for t in raw_stamps if t >= clock[0]]
    assert len(clock) >= len(since_matched) - 5 and len(since_matched) >= len(raw_stamps) // 2
