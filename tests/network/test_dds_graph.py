"""ros_discovery_info: the publisher tells ROS 2 tools that node /fingertip owns its readers
and writers (rmw_dds_common's ParticipantEntitiesInfo as of Jazzy, decoded with rosbags'
Jazzy types); the GIDs are the GUIDs DDS discovery reports for those endpoints."""
from __future__ import annotations

import signal
import time
import uuid

from rosbags.typesys import Stores, get_typestore

from fingertip.network.dds import LATCHED, DdsNode
from fingertip.network.ros_types import PARTICIPANT_ENTITIES

from .conftest import start, wait_line


def test_the_node_and_its_endpoints_are_announced():
    # Until stopped: a publisher that ended on its own before a busy machine discovered it
    # would take its announcement with it.
    node = DdsNode()
    pub = start("publish", "--virtual", "1", "--name", "index", "--duration", "120")
    infos: list[bytes] = []
    try:
        wait_line(pub, "publishing")
        node.reader("ros_discovery_info", PARTICIPANT_ENTITIES, LATCHED, infos.append)
        from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication

        pubs = BuiltinDataReader(node.participant, BuiltinTopicDcpsPublication)
        store = get_typestore(Stores.ROS2_JAZZY)
        t_end = time.monotonic() + 20
        mine = None
        while time.monotonic() < t_end and mine is None:
            time.sleep(0.2)
            for data in list(infos):
                msg = store.deserialize_cdr(data, PARTICIPANT_ENTITIES)
                nodes = [n for n in msg.node_entities_info_seq if n.node_name == "fingertip"]
                if nodes and len(nodes[0].writer_gid_seq) >= 6:
                    mine = (msg, nodes[0])
        assert mine is not None, "no ros_discovery_info from the publisher"
        msg, info = mine
        assert info.node_namespace == "/" and len(bytes(msg.gid.data)) == 16
        time.sleep(0.5)
        endpoints = {s.key: s.topic_name for s in pubs.take(N=500)
                     if s.topic_name.startswith(("rt/fingertip/index/", "rr/fingertip/index/"))}
        writers = {uuid.UUID(bytes=bytes(g.data)) for g in info.writer_gid_seq}
        # Five topics and the tare service's reply writer, each with the GUID DDS reports.
        assert set(endpoints) <= writers and len(endpoints) == 6, (endpoints, writers)
        assert len(info.reader_gid_seq) == 1  # the tare service's request reader
    finally:
        node.close()
        pub.send_signal(signal.SIGINT)
        _, err = pub.communicate(timeout=60)
    assert pub.returncode == 0, err  # Ctrl-C is how a user ends publishing: a clean end
