"""A hand of two virtual fingertips published over DDS; the wrench of one of them read as a
reference force sensor (`WrenchReference`, what `calibrate` can take as its reference)."""
from __future__ import annotations

import pytest

from fingertip.network.reference import WrenchReference

from .conftest import start
from .test_dds_stream import FORCE_MODEL


def test_a_hand_of_two_and_a_wrench_reference():
    with WrenchReference("/fingertip/thumb/wrench") as ref:
        pub = start("publish", "--virtual", "2", "--name", "index,thumb", "--force-model",
                    FORCE_MODEL, "--duration", "3")
        try:
            got = []
            while len(got) < 80 and (m := ref.get(timeout=20.0)) is not None:
                got.append(m)
        finally:
            _, err = pub.communicate(timeout=60)
        assert pub.returncode == 0, err
        assert "/fingertip/index/raw" in err and "/fingertip/thumb/raw" in err
    assert len(got) == 80 and {m.frame_id for m in got} == {"thumb"}
    stamps = [m.stamp_ns for m in got]
    assert stamps == sorted(stamps) and ref.bad == 0
    assert all(m.torque == (0.0, 0.0, 0.0) and m.force[2] == 0.0 for m in got)


def test_reference_topic_must_be_absolute():
    with pytest.raises(ValueError, match="must start with"):
        WrenchReference("ft_sensor/wrench")


def test_ros_domain_id_separates_networks(monkeypatch):
    """ROS_DOMAIN_ID is honoured: a reader on another domain hears nothing."""
    import os

    domain = int(os.environ["ROS_DOMAIN_ID"])
    same = WrenchReference("/fingertip/index/wrench")
    monkeypatch.setenv("ROS_DOMAIN_ID", str(domain + 1))
    other = WrenchReference("/fingertip/index/wrench")
    monkeypatch.setenv("ROS_DOMAIN_ID", str(domain))
    try:
        pub = start("publish", "--virtual", "1", "--name", "index", "--force-model",
                    FORCE_MODEL, "--duration", "2")
        got = same.get(timeout=20.0)
        _, err = pub.communicate(timeout=60)
        assert pub.returncode == 0, err
        assert got is not None and got.frame_id == "index"
        assert other.get(timeout=0.5) is None
    finally:
        same.close()
        other.close()


def test_a_wrench_topic_as_the_calibration_reference():
    """`calibrate record --ros-topic`: the topic's samples, timed on this host's monotonic
    clock (the fingertip frames' clock), as the ReferenceSamples the join takes."""
    import time

    import numpy as np

    from fingertip.network.reference import WrenchTopicSource

    src = WrenchTopicSource("/fingertip/index/wrench")
    src.start()
    t0 = time.monotonic()
    pub = start("publish", "--virtual", "1", "--name", "index", "--force-model",
                FORCE_MODEL, "--duration", "3")
    try:
        _, err = pub.communicate(timeout=60)
    finally:
        ref = src.stop()
    assert pub.returncode == 0, err
    assert len(ref) >= 100 and ref.force.shape == (len(ref), 3)
    assert ref.torque is not None and ref.torque.shape == (len(ref), 3)
    assert np.all(np.diff(ref.times_s) >= 0) and t0 <= ref.times_s[0] <= time.monotonic()
    assert ref.counters["messages"] == len(ref) and ref.counters["bad"] == 0
    assert ref.source == "dds:/fingertip/index/wrench"
    with pytest.raises(RuntimeError, match="not started"):
        src.stop()
