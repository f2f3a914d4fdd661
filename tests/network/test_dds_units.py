"""Type names, hashes, payload layout, discovery settings and request checks, without a
network; the missing-extra error in a subprocess with the package import blocked."""
from __future__ import annotations

import subprocess
import sys

import pytest
from rosbags.typesys import Stores, get_typestore

from fingertip.network import ros2pkg
from fingertip.network.dds import (
    DdsError,
    check_trigger_request,
    decode_trigger_reply,
    discovery_config,
    domain_id,
    encode_request,
    encode_trigger_reply,
)
from fingertip.network.ros_types import dds_type_name, idl_struct, type_hash
from fingertip.record import schemas as S

from .conftest import ROOT, env


def test_type_names_follow_rmw():
    assert dds_type_name(S.WRENCH_STAMPED) == "geometry_msgs::msg::dds_::WrenchStamped_"
    assert dds_type_name(S.STRAIN_RAW) == "fingertip_msgs::msg::dds_::StrainRaw_"
    assert dds_type_name("std_srvs/srv/Trigger_Request") == \
        "std_srvs::srv::dds_::Trigger_Request_"


@pytest.mark.parametrize("store", [Stores.ROS2_HUMBLE, Stores.ROS2_JAZZY, Stores.ROS2_KILTED])
def test_standard_type_hashes_match_ros2(store):
    ts = get_typestore(store)
    for name in (S.WRENCH_STAMPED, S.STRING, "std_msgs/msg/Header", "rosgraph_msgs/msg/Clock"):
        assert type_hash(name) == ts.hash_rihs01(name)


def test_discovery_info_types_match_jazzy_and_kilted():
    """ros_discovery_info's types, from our definitions, hash as rmw_dds_common's do."""
    from fingertip.network.ros_types import GID, NODE_ENTITIES, PARTICIPANT_ENTITIES

    for store in (Stores.ROS2_JAZZY, Stores.ROS2_KILTED):
        ts = get_typestore(store)
        for name in (GID, NODE_ENTITIES, PARTICIPANT_ENTITIES):
            assert type_hash(name) == ts.hash_rihs01(name)


def test_custom_type_hashes_are_stable_and_distinct():
    hashes = {type_hash(n) for n in (S.STRAIN_RAW, S.AUDIO_CHUNK, S.EVENT)}
    assert len(hashes) == 3 and all(h.startswith("RIHS01_") and len(h) == 71 for h in hashes)


def _idl_sample(name: str, msg):
    """The same message as a cyclonedds IdlStruct instance."""
    Time, Header = idl_struct("builtin_interfaces/msg/Time"), idl_struct("std_msgs/msg/Header")

    def hdr(ns, frame_id):
        sec, nsec = S.stamp_of(ns)
        return Header(stamp=Time(sec=sec, nanosec=nsec), frame_id=frame_id)
    cls = idl_struct(name)
    if name == S.STRAIN_RAW:
        sec, nsec = S.stamp_of(msg.arrival_ns)
        return cls(header=hdr(msg.stamp_ns, msg.frame_id), seq=msg.seq,
                   device_time_us=msg.device_time_us, arrival=Time(sec=sec, nanosec=nsec),
                   counts=list(msg.counts), timeout_mask=msg.timeout_mask,
                   saturation_mask=msg.saturation_mask)
    if name == S.AUDIO_CHUNK:
        return cls(header=hdr(msg.stamp_ns, msg.frame_id), first_index=msg.first_index,
                   frames=msg.frames, channels=msg.channels, sample_rate=msg.sample_rate,
                   host_rate=msg.host_rate, lost_before=msg.lost_before,
                   encoding=msg.encoding, data=list(msg.data))
    if name == S.EVENT:
        return cls(header=hdr(msg.stamp_ns, msg.frame_id), kind=msg.kind, value=msg.value,
                   detail=msg.detail)
    V, W = idl_struct("geometry_msgs/msg/Vector3"), idl_struct("geometry_msgs/msg/Wrench")
    return cls(header=hdr(msg.stamp_ns, msg.frame_id),
               wrench=W(force=V(*msg.force), torque=V(*msg.torque)))


MESSAGES = [
    (S.STRAIN_RAW, S.encode_raw, S.RawMsg(1_700_000_000_123_456_789, "index", 0xFFFFFFFF,
                                          2**40 + 3, 1_700_000_000_200_000_000,
                                          (-8388608, 8388607, 0, 5), 0b0101, 0b1000)),
    (S.STRAIN_RAW, S.encode_raw, S.RawMsg(0, "a", 0, 0, 0, (), 0, 0)),
    (S.WRENCH_STAMPED, S.encode_wrench, S.WrenchMsg(5, "thumb_1", (1.5, -2.0, 1e-300),
                                                    (0.0, -0.0, 3.0))),
    (S.AUDIO_CHUNK, S.encode_audio, S.AudioMsg(7, "index", 44100 * 3600, 3, 1, 44100.0,
                                               44099.9, 2, "S16LE", b"\x01\x00\xff\x7f\x00")),
    (S.EVENT, S.encode_event, S.EventMsg(9, "index", "contact_make", 0.5, "{\"n\": 1}")),
    (S.EVENT, S.encode_event, S.EventMsg(9, "index", "", 0.0, "é")),
]


@pytest.mark.parametrize("name,encode,msg", MESSAGES)
def test_recorder_bytes_equal_cyclonedds_serialisation(name, encode, msg):
    """Three implementations agree: the recorder's encoder, Cyclone's Python serialiser
    for the type we register on DDS, and rosbags' (checked in test_dds_stream)."""
    ours = encode(msg)
    theirs = _idl_sample(name, msg).serialize(use_version_2=False)
    assert theirs[:len(ours)] == ours and set(theirs[len(ours):]) <= {0}


def test_fingertip_msgs_package_matches_the_recorder():
    """ros2/fingertip_msgs is what the generator writes from the recorder's definitions."""
    pkg = ROOT / "ros2" / "fingertip_msgs"
    expected = ros2pkg.files()
    on_disk = {str(p.relative_to(pkg)): p.read_text() for p in pkg.rglob("*") if p.is_file()}
    assert on_disk == expected, "run: python -m fingertip.network.ros2pkg ros2/fingertip_msgs"
    for name in (S.STRAIN_RAW, S.AUDIO_CHUNK, S.EVENT):
        assert f'"msg/{name.split("/")[-1]}.msg"' in expected["CMakeLists.txt"]


def test_discovery_follows_ros2_environment():
    assert discovery_config({}) is None  # SUBNET: Cyclone's defaults (multicast)
    local = discovery_config({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"})
    assert '<NetworkInterface address="127.0.0.1"/>' in local
    assert "<AllowMulticast>false</AllowMulticast>" in local
    assert '<Peer address="127.0.0.1"/>' in local
    assert discovery_config({"ROS_LOCALHOST_ONLY": "1"}) == local
    peers = discovery_config({"ROS_STATIC_PEERS": "10.0.0.2;robot.local"})
    assert '<Peer address="10.0.0.2"/>' in peers and '<Peer address="robot.local"/>' in peers
    assert "AllowMulticast" not in peers  # SUBNET keeps multicast, adds the peers
    off = discovery_config({"ROS_AUTOMATIC_DISCOVERY_RANGE": "OFF",
                            "ROS_STATIC_PEERS": "10.0.0.2"})
    assert "<AllowMulticast>false</AllowMulticast>" in off and "10.0.0.2" in off
    assert "127.0.0.1" not in off
    assert discovery_config({"CYCLONEDDS_URI": "file:///x.xml",
                             "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}) is None
    with pytest.raises(DdsError, match="ROS_AUTOMATIC_DISCOVERY_RANGE"):
        discovery_config({"ROS_AUTOMATIC_DISCOVERY_RANGE": "MOON"})
    assert discovery_config({"ROS_STATIC_PEERS": '"/><x a="'}).count("<x") == 0


def test_domain_id():
    assert domain_id({}) == 0 and domain_id({"ROS_DOMAIN_ID": "42"}) == 42
    for bad in ("x", "-1", "233"):
        with pytest.raises(DdsError, match="ROS_DOMAIN_ID"):
            domain_id({"ROS_DOMAIN_ID": bad})


def test_trigger_request_checks():
    good = encode_request((7, 3))
    assert len(good) == 24 and check_trigger_request(good) == ((7, 3), None, "")
    assert check_trigger_request(b"")[1] == "malformed"
    assert check_trigger_request(b"\x00\x01\x00\x00" + b"\x01" * 8)[:2] == (None, "malformed")
    assert check_trigger_request(b"\x07\x07\x00\x00" + b"\x00" * 40)[:2] == (None, "malformed")
    assert check_trigger_request(good[:20]) [:2] == ((7, 3), "malformed")
    assert check_trigger_request(encode_request((7, 4), b"\0" * 100))[:2] == ((7, 4),
                                                                             "oversized")
    big_endian = b"\x00\x00\x00\x00" + (7).to_bytes(8, "big") + (5).to_bytes(8, "big") + b"\0"
    assert check_trigger_request(big_endian)[:2] == ((7, 5), None)


def test_trigger_reply_layout():
    """std_srvs/srv/Trigger_Response after rmw_cyclonedds' request id (uint64, int64)."""
    data = encode_trigger_reply((0x0102030405060708, -2), True, "ok")
    assert data[:4] == b"\x00\x01\x00\x00"
    assert data[4:12] == bytes.fromhex("0807060504030201")
    assert data[12:20] == (-2).to_bytes(8, "little", signed=True)
    assert data[20:21] == b"\x01" and data[24:28] == (3).to_bytes(4, "little")
    assert data[28:31] == b"ok\0" and len(data) % 4 == 0
    assert decode_trigger_reply(data) == ((0x0102030405060708, -2), True, "ok")


BLOCK = ("import sys; sys.modules[{mod!r}] = None; from fingertip.cli import main; "
         "sys.exit(main({argv!r}))")


@pytest.mark.parametrize("mod,argv,extra", [
    ("cyclonedds", ["publish", "--virtual", "1", "--duration", "1"], "ros"),
    ("zenoh", ["publish", "--virtual", "1", "--transport", "zenoh", "--duration", "1"],
     "zenoh"),
    ("pylsl", ["publish", "--virtual", "1", "--transport", "lsl", "--duration", "1"], "lsl"),
    ("zenoh", ["record", "--from", "zenoh", "-o", "{out}"], "zenoh"),
    ("cyclonedds", ["record", "--from", "dds", "-o", "{out}"], "ros"),
    ("pylsl", ["record", "--from", "lsl", "-o", "{out}"], "lsl"),
])
def test_missing_extra_is_one_line_and_exit_2(tmp_path, mod, argv, extra):
    argv = [a.replace("{out}", str(tmp_path / "x.mcap")) for a in argv]
    r = subprocess.run([sys.executable, "-c", BLOCK.format(mod=mod, argv=argv)], env=env(),
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, r.stderr
    assert f"pip install 'fingertip[{extra}]'" in lines[0]
    assert not (tmp_path / "x.mcap").exists()  # nothing half-made left behind


def test_bad_discovery_setting_is_one_line_and_leaves_no_file(tmp_path):
    out = tmp_path / "x.mcap"
    e = env()
    e["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "MOON"
    r = subprocess.run([sys.executable, "-m", "fingertip.cli", "record", "--from", "dds", "-o",
                        str(out)], env=e, capture_output=True, text=True, timeout=60)
    assert r.returncode == 2
    assert [ln for ln in r.stderr.splitlines() if ln.strip()] == [
        "ERROR fingertip: ROS_AUTOMATIC_DISCOVERY_RANGE='MOON': use SUBNET, LOCALHOST, OFF or "
        "SYSTEM_DEFAULT"]
    assert not out.exists()


def test_paired_audio_needs_a_usb_port(tmp_path):
    """--audio paired looks for the sound card on the fingertip's USB hub; a pty has none:
    one line, exit 2 (the pairing itself needs USB hardware, not here)."""
    from fingertip.sim import VirtualFirmware
    from fingertip.sim.device.pty_device import PtyDevice

    with PtyDevice(VirtualFirmware(4)) as dev:
        r = subprocess.run([sys.executable, "-m", "fingertip.cli", "publish", "--port",
                            dev.port, "--audio", "paired", "--duration", "1"], env=env(),
                           capture_output=True, text=True, timeout=60)
    assert r.returncode == 2
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "not a USB serial port" in lines[0], r.stderr


def test_service_counts_say_what_was_dropped_before_reaching_the_service():
    from fingertip.network.trigger import ServiceStats

    st = ServiceStats(requests=5, answered=1, refused=4, reasons={"busy": 4})
    assert st.dropped == 0
    assert st.text() == "5 requests, 1 answered, 4 refused {'busy': 4}, 0 dropped"
    st.dropped_by = lambda: 3  # the transport's count (DDS: lost and rejected samples)
    assert st.text().endswith(", 3 dropped")
    assert ServiceStats(requests=2, answered=2).text() == ("2 requests, 2 answered, 0 refused, "
                                                          "0 dropped")
