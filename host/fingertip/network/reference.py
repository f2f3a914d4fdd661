"""A reference force sensor on the network: any ``geometry_msgs/WrenchStamped`` topic (a
force/torque sensor on the robot's wrist, another fingertip), over DDS or Zenoh, as a stream
of :class:`~fingertip.record.schemas.WrenchMsg` for calibration against a reference.

>>> with WrenchReference("/ft_sensor/wrench") as ref:       # doctest: +SKIP
...     m = ref.get(timeout=1.0)      # WrenchMsg: stamp_ns, frame_id, force, torque
"""
from __future__ import annotations

import logging
import queue

from ..record import schemas as S

log = logging.getLogger(__name__)


class WrenchReference:
    """Subscribe to ``topic`` (``/a/b``) of type geometry_msgs/msg/WrenchStamped.

    The DDS reader asks for best effort, so it matches reliable and best-effort publishers
    alike; it keeps up to ``depth`` samples the caller has not taken yet (older ones are
    dropped and counted in :attr:`dropped`). Messages that do not decode are counted in
    :attr:`bad`.
    """

    def __init__(self, topic: str, transport: str = "dds", *, depth: int = 10000,
                 connect: list[str] | None = None) -> None:
        if not topic.startswith("/"):
            raise ValueError(f"topic {topic!r} must start with '/'")
        self.topic = topic
        self.bad = 0
        self.dropped = 0
        self._queue: queue.Queue = queue.Queue(maxsize=depth)
        if transport == "dds":
            from .dds import SENSOR, DdsNode, ros_topic

            self._node = DdsNode()
            self._node.reader(ros_topic(topic), S.WRENCH_STAMPED, SENSOR, self._on_data,
                              depth=1000)
        elif transport == "zenoh":
            from .zenoh import ZenohNode, key_expr

            self._node = ZenohNode(connect)
            self._sub = self._node.session.declare_subscriber(
                key_expr(self._node.domain, topic, S.WRENCH_STAMPED),
                lambda sample: self._on_data(sample.payload.to_bytes()))
        else:
            raise ValueError(f"transport {transport!r}: dds or zenoh")

    def _on_data(self, data: bytes) -> None:
        try:
            msg = S.decode_wrench(data)
        except Exception:  # not a WrenchStamped: count it, keep listening
            self.bad += 1
            return
        try:
            self._queue.put_nowait(msg)
        except queue.Full:
            self.dropped += 1

    def get(self, timeout: float | None = None) -> S.WrenchMsg | None:
        """The next wrench, or None after ``timeout`` seconds."""
        try:
            return self._queue.get(timeout=timeout)
        except queue.Empty:
            return None

    def close(self) -> None:
        self._node.close()

    def __enter__(self) -> WrenchReference:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
