"""A 10 s virtual fingertip run over DDS (and Zenoh: test_zenoh_stream), received by
`fingertip record --from ...` in another process: every message arrives, byte for byte what
the publisher's local recording holds, and an independent CDR implementation (rosbags)
decodes it to the same values."""
from __future__ import annotations

import signal
import time
from collections import defaultdict
from pathlib import Path

import pytest
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from fingertip.record import schemas as S
from fingertip.record.reader import Recording

from .conftest import ROOT, start, wait_line

FORCE_MODEL = "tests.record.conftest:force_model"


def by_topic(path: Path) -> dict[str, list[tuple[int, bytes]]]:
    out: dict[str, list[tuple[int, bytes]]] = defaultdict(list)
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        for _schema, channel, message in make_reader(f).iter_messages(log_time_order=False):
            out[channel.topic].append((message.log_time, bytes(message.data)))
    return out


def rosbags_store():
    """rosbags' own ROS 2 types, plus ours from the shipped ROS 2 package's .msg files."""
    store = get_typestore(Stores.ROS2_JAZZY)
    types = {}
    for p in sorted((ROOT / "ros2" / "fingertip_msgs" / "msg").glob("*.msg")):
        types.update(get_types_from_msg(p.read_text(), f"fingertip_msgs/msg/{p.stem}"))
    store.register(types)
    return store


def unpadded(received: bytes, local: bytes) -> bool:
    """DDS payloads are padded with zeros to a multiple of 4 bytes (as rmw_cyclonedds does)."""
    return received[:len(local)] == local and set(received[len(local):]) <= {0} \
        and len(received) - len(local) < 4


def as_values(kind: str, msg) -> tuple:
    """The values a rosbags message holds, in the order of our message objects."""
    h = msg.header if kind != "info" else None
    st = (h.stamp.sec * S.NS + h.stamp.nanosec, h.frame_id) if h else ()
    if kind == "raw":
        return (*st, msg.seq, msg.device_time_us,
                msg.arrival.sec * S.NS + msg.arrival.nanosec, tuple(int(c) for c in msg.counts),
                msg.timeout_mask, msg.saturation_mask)
    if kind == "wrench":
        w = msg.wrench
        return (*st, (w.force.x, w.force.y, w.force.z), (w.torque.x, w.torque.y, w.torque.z))
    if kind == "audio":
        return (*st, msg.first_index, msg.frames, msg.channels, msg.sample_rate, msg.host_rate,
                msg.lost_before, msg.encoding, bytes(msg.data))
    if kind == "events":
        return (*st, msg.kind, msg.value, msg.detail)
    return (msg.data,)


def ours(kind: str, data: bytes) -> tuple:
    m = S.DECODERS[S.TOPIC_KINDS[kind]](data)
    if kind == "info":
        return (m,)
    vals = []
    for f in m.__dataclass_fields__:
        v = getattr(m, f)
        vals.append(tuple(v) if isinstance(v, tuple) else v)
    return tuple(vals)


def run_and_compare(tmp_path, transport: str, sub_args=(), pub_args=(), during=None,
                    subscribers: int = 1):
    """Publish a 10 s virtual run over ``transport`` while `record --from` records it in
    another process; check every message against the publisher's local recording."""
    local, remote = tmp_path / "local.mcap", tmp_path / "remote.mcap"
    sub = start("record", "--from", transport, "--name", "index", "-o", str(remote),
                *sub_args)
    try:
        wait_line(sub, f"recording index from {transport}")
        pub = start("publish", "--transport", transport, "--virtual", "1", "--name", "index",
                    "--virtual-audio", "--force-model", FORCE_MODEL, "--duration", "10",
                    "--record", str(local), "--wait-subscribers", str(subscribers),
                    "--wait-timeout", "30", *pub_args)
        if during is not None:
            during()
        out, err = pub.communicate(timeout=60)
        assert pub.returncode == 0, err
        time.sleep(0.5)
    finally:
        sub.send_signal(signal.SIGTERM)
        sub_out, sub_err = sub.communicate(timeout=30)
    assert sub.returncode == 0, sub_err
    a, b = by_topic(local), by_topic(remote)
    assert sorted(a) == sorted(S.topic("index", k) for k in S.TOPIC_KINDS)
    assert len(a[S.topic("index", "raw")]) >= 780  # 10 s at 80 Hz
    assert sum(len(a[t]) for t in a) > 1800
    store = rosbags_store()
    for topic_name, sent in a.items():
        got = b[topic_name]
        assert len(got) == len(sent), topic_name  # every message: none lost, none doubled
        kind = S.split_topic(topic_name)[1]
        schema = S.TOPIC_KINDS[kind]
        # Same messages in the same order (per topic), bytes identical up to DDS padding.
        for (t_local, d_local), (t_remote, d_remote) in zip(sent, got, strict=True):
            assert unpadded(d_remote, d_local), topic_name
            if kind != "info":
                assert t_remote == t_local  # logged at the header stamp, like the original
            assert as_values(kind, store.deserialize_cdr(d_remote, schema)) == ours(kind,
                                                                                     d_local)
    assert "dropped 0" in sub_err and "undecodable 0" in sub_err
    # What the recording holds is readable by our own reader too.
    assert Recording(remote).names() == ["index"]
    return a


@pytest.mark.slow
def test_every_message_of_a_10s_run_arrives_and_decodes_independently(tmp_path):
    run_and_compare(tmp_path, "dds")
