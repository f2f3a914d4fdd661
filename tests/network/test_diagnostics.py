"""/diagnostics: the rules (table-driven), the message as ROS 2 defines it (decoded by rosbags,
an independent decoder, and hashed as rosbags hashes its own copy), and a publisher in
another process over DDS and Zenoh whose device loses a chip, goes away and comes back."""
from __future__ import annotations

import queue
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from rosbags.typesys import Stores, get_typestore

from fingertip.network.diagnostics import (
    DIAGNOSTIC_ARRAY, DIAGNOSTIC_STATUS, ERROR, HOLD_S, KEY_VALUE, OK, WARN, Health, Status,
    Window, assess, encode_diagnostic_array, status_of,
)
from fingertip.network.ros_types import type_hash

from .conftest import env, start

ROS2 = get_typestore(Stores.ROS2_JAZZY)

# (case, window, level, words in the message)
RULES = [
    ("all well", Window(frames=80, channels=4), OK, "streaming"),
    ("not started", Window(streaming=False, channels=4), OK, "idle"),
    ("frames lost", Window(frames=80, channels=4, grown={"frames_lost": 3}), WARN,
     "frames lost (3 in 10 s)"),
    ("CRC errors", Window(frames=80, channels=4, grown={"crc_errors": 1}), WARN,
     "CRC errors (1 in 10 s)"),
    ("framing errors add up", Window(frames=80, channels=4,
                                     grown={"cobs_errors": 2, "length_errors": 1}), WARN,
     "framing errors (3 in 10 s)"),
    ("reconnected", Window(frames=80, channels=4, grown={"reconnects": 1}), WARN,
     "reconnected (1 in 10 s)"),
    ("device restarted", Window(frames=80, channels=4, grown={"device_resets": 1}), WARN,
     "device restarted"),
    ("queue overruns", Window(frames=80, channels=4, grown={"overruns": 9}), WARN,
     "frames overrun in the queue"),
    ("audio overruns", Window(frames=80, channels=4, grown={"audio.overruns_frames": 441}),
     WARN, "audio frames overrun (441 in 10 s)"),
    ("a chip absent", Window(frames=80, channels=4, timeout_any=0b0010, timeout_all=0b0010),
     WARN, "chips absent or failing on channel 1"),
    ("saturated", Window(frames=80, channels=4, saturated_any=0b1001), WARN,
     "saturated on channel 0,3"),
    ("several at once", Window(frames=80, channels=4, grown={"frames_lost": 2},
                               saturated_any=1), WARN,
     "frames lost (2 in 10 s); saturated on channel 0"),
    ("device away", Window(connected=False, gone_s=3.2, channels=4), ERROR,
     "device away for 3 s, reconnecting"),
    ("no chip answers", Window(frames=80, channels=4, timeout_any=15, timeout_all=15), ERROR,
     "no chip answers"),
    ("connected but silent", Window(frames=0, channels=4, silent_s=2.5), ERROR,
     "no frames for 2 s"),
    ("slow but alive", Window(frames=0, channels=4, silent_s=2.5, frame_period_s=1.0), OK,
     "streaming"),
]


@pytest.mark.parametrize("case, window, level, words", RULES, ids=[r[0] for r in RULES])
def test_the_rules_of_docs_reliability(case, window, level, words):
    got_level, message = assess(window)
    assert got_level == level and words in message, message


def test_the_rules_table_is_in_the_docs():
    doc = (Path(__file__).resolve().parents[2] / "docs" / "reliability.md").read_text()
    section = doc[doc.index("## Health on /diagnostics"):]
    for words in ("device away", "no chip answers", "no frames", "frames lost", "CRC errors",
                  "reconnected", "device restarted", "saturated", "chips absent",
                  "audio frames overrun", f"{HOLD_S:g} s"):
        assert words in section, words


def test_the_message_is_rosbags_diagnostic_array_byte_for_byte():
    # Our definitions hash as ROS 2's own (rosbags' copy of diagnostic_msgs).
    for t in (DIAGNOSTIC_ARRAY, DIAGNOSTIC_STATUS, KEY_VALUE):
        assert type_hash(t) == ROS2.hash_rihs01(t)
    statuses = [Status(WARN, "fingertip: index", "frames lost (3 in 10 s)", "A1B2C3",
                       (("frames_lost", "3"), ("status", "connected"))),
                Status(OK, "fingertip: thümb", "streaming", "none", ())]
    data = encode_diagnostic_array(1_700_000_000_123_456_789, statuses)
    m = ROS2.deserialize_cdr(data, DIAGNOSTIC_ARRAY)
    assert (m.header.stamp.sec, m.header.stamp.nanosec, m.header.frame_id) == (
        1_700_000_000, 123_456_789, "")
    assert [(s.level, s.name, s.message, s.hardware_id,
             [(kv.key, kv.value) for kv in s.values]) for s in m.status] == [
        (1, "fingertip: index", "frames lost (3 in 10 s)", "A1B2C3",
         [("frames_lost", "3"), ("status", "connected")]),
        (0, "fingertip: thümb", "streaming", "none", [])]
    assert ROS2.serialize_cdr(m, DIAGNOSTIC_ARRAY) == data


def test_a_status_is_named_as_diagnostic_updater_names_it():
    s = status_of("index", "", Window(frames=80, channels=4, counters={"frames_lost": 0}),
                  80.0)
    assert s.name == "fingertip: index" and s.hardware_id == "none"
    assert dict(s.values)["frame_rate_hz"] == "80.0" and dict(s.values)["frames_lost"] == "0"


def test_health_gathers_frames_and_counters_between_updates():
    class Src:
        serial_number, port, channels, status, gone_s = "85036313530351D0F1A1", "", 4, \
            "connected", None

        class stats:  # noqa: N801 - stands for a BridgeStats
            frames_ok, frames_lost, crc_errors, reconnects = 100, 0, 0, 0

    class F:
        def __init__(self, t, s):
            self.timeout_mask, self.saturation_mask = t, s

    src = Src()
    h = Health(src, "index")
    for k in range(80):
        h.on_frame(F(0b0100, 0b0001 if k == 5 else 0))
    s = h.update(100.0)
    assert s.level == WARN and s.hardware_id == "85036313530351D0F1A1"
    v = dict(s.values)
    assert (v["absent_channels"], v["timeout_channels"], v["saturated_channels"]) == (
        "2", "2", "0")
    for _ in range(80):
        h.on_frame(F(0, 0))
    Src.stats.frames_lost = 4  # lost in this period: WARN for HOLD_S
    s = h.update(101.0)
    assert s.level == WARN and "frames lost (4 in 10 s)" in s.message
    assert dict(s.values)["frame_rate_hz"] == "80.0"
    for t in range(2, 12):
        for _ in range(80):
            h.on_frame(F(0, 0))
        s = h.update(100.0 + t)
    assert s.level == OK and s.message == "streaming"  # HOLD_S later: well again


# --- a publisher in another process ---------------------------------------------------------

def sim_device(link: Path, *faults: str) -> subprocess.Popen:
    args = [a for f in faults for a in ("--fault", f)]
    p = subprocess.Popen([sys.executable, "-m", "fingertip.cli", "sim", "device", "--link",
                          str(link), *args], env=env(), stdout=subprocess.DEVNULL,
                         stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 30
    while not link.exists() and time.monotonic() < deadline:
        time.sleep(0.02)
    return p


def decode(data: bytes):
    m = ROS2.deserialize_cdr(bytes(data), DIAGNOSTIC_ARRAY)
    return m.header.stamp.sec + m.header.stamp.nanosec * 1e-9, list(m.status)


def collect(q: queue.Queue, until) -> list:
    got = []
    deadline = time.monotonic() + 40
    while time.monotonic() < deadline:
        try:
            got.append(decode(q.get(timeout=0.5)))
        except queue.Empty:
            continue
        if until(got):
            break
    return got


def test_dds_diagnostics_follow_a_device_that_loses_a_chip_goes_away_and_comes_back(
        tmp_path):
    from fingertip.network.dds import RELIABLE, DdsNode

    link = tmp_path / "ft"
    dev = sim_device(link, "missing-chip:1")
    node = DdsNode()
    pub = start("publish", "--port", str(link), "--name", "index", "--duration", "40")
    try:
        q: queue.Queue = queue.Queue()
        node.reader("rt/diagnostics", DIAGNOSTIC_ARRAY, RELIABLE, q.put, depth=0)
        before = collect(q, lambda g: len(g) >= 3)
        dev.kill()
        dev.wait()
        link.unlink()
        away = collect(q, lambda g: g[-1][1][0].level == ERROR)
        time.sleep(1.5)
        dev = sim_device(link, "missing-chip:1")
        back = collect(q, lambda g: "device restarted" in g[-1][1][0].message)
    finally:
        node.close()
        pub.send_signal(signal.SIGINT)
        pub.communicate(timeout=30)
        dev.kill()
        dev.wait()
    stamps = [t for t, _ in before]
    assert all(0.8 < b - a < 1.3 for a, b in zip(stamps, stamps[1:], strict=False))  # 1 Hz
    s = before[-1][1]
    assert len(s) == 1 and s[0].name == "fingertip: index" and s[0].hardware_id == str(link)
    assert s[0].level == WARN and "chips absent or failing on channel 1" in s[0].message
    assert away[-1][1][0].message.startswith("device away")
    v = {kv.key: kv.value for kv in back[-1][1][0].values}
    assert back[-1][1][0].level == WARN and "frames lost" in back[-1][1][0].message
    assert int(v["device_resets"]) == 1 and int(v["reconnects"]) == 1
    assert int(v["outage_frames"]) >= 1.5 * 80 and v["frames_lost"] == v["outage_frames"]


def test_zenoh_diagnostics_as_rmw_zenoh_keys_them():
    pytest.importorskip("zenoh")
    from fingertip.network import zenoh as Z

    from .test_zenoh_service import zenoh_publisher

    with zenoh_publisher({}) as node:
        q: queue.Queue = queue.Queue()
        ke = Z.key_expr(node.domain, "/diagnostics", DIAGNOSTIC_ARRAY)
        assert ke == (f"{node.domain}/diagnostics/diagnostic_msgs::msg::dds_::"
                      f"DiagnosticArray_/{ROS2.hash_rihs01(DIAGNOSTIC_ARRAY)}")
        sub = node.session.declare_subscriber(ke, lambda s: q.put(s.payload.to_bytes()))
        got = collect(q, lambda g: len(g) >= 3)
        sub.undeclare()
    assert len(got) >= 3
    s = got[-1][1][0]
    assert (s.level, s.name, s.message) == (OK, "fingertip: index", "streaming")
    assert {kv.key for kv in s.values} >= {"frames_lost", "outage_frames", "device_resets",
                                           "crc_errors", "reconnects", "frame_rate_hz"}
