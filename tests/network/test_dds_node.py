"""DdsNode.close() lets the domain go, even while the closed node is still referenced."""
from __future__ import annotations

from fingertip.network.dds import RELIABLE, DdsNode
from fingertip.network.ros_types import CLOCK

from .conftest import domain_id


def test_a_closed_node_still_referenced_frees_its_domain_for_other_settings():
    # A failed test keeps its closed node alive in the traceback: the next test's node on
    # the same domain with other discovery settings got PRECONDITION_NOT_MET, and a tare
    # service of the old node was still found (busy run 2 of session 12's series).
    domain = str(domain_id() + 1)
    first = DdsNode({"ROS_DOMAIN_ID": domain, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"})
    first.reader("rt/clock", CLOCK, RELIABLE, lambda _d: None)
    first.writer("rt/clock", CLOCK, RELIABLE)
    first.trigger_service("/fingertip/test/tare", lambda: (True, ""))
    first.announce()
    first.close()
    assert first.participant is None
    second = DdsNode({"ROS_DOMAIN_ID": domain, "ROS_AUTOMATIC_DISCOVERY_RANGE": "OFF",
                      "ROS_STATIC_PEERS": "127.0.0.1"})
    try:
        assert second.participant is not None
    finally:
        second.close()
