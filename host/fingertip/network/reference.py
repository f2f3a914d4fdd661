"""A reference force sensor on the network: any ``geometry_msgs/WrenchStamped`` topic (a
force/torque sensor on the robot's wrist, another fingertip), over DDS or Zenoh, as a stream
of :class:`~fingertip.record.schemas.WrenchMsg` for calibration against a reference.

>>> with WrenchReference("/ft_sensor/wrench") as ref:       # doctest: +SKIP
...     m = ref.get(timeout=1.0)      # WrenchMsg: stamp_ns, frame_id, force, torque
"""
from __future__ import annotations

import logging
import queue
import threading
import time

import numpy as np

from ..record import schemas as S
from ..reference.samples import ReferenceSamples

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
            self._queue.put_nowait((time.monotonic(), msg))
        except queue.Full:
            self.dropped += 1

    def get(self, timeout: float | None = None) -> S.WrenchMsg | None:
        """The next wrench, or None after ``timeout`` seconds."""
        got = self.get_timed(timeout)
        return None if got is None else got[1]

    def get_timed(self, timeout: float | None = None) -> tuple[float, S.WrenchMsg] | None:
        """The next wrench with its arrival time on this host's ``time.monotonic()`` clock,
        or None after ``timeout`` seconds."""
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


class WrenchTopicSource:
    """A ``WrenchStamped`` topic as the live reference of ``fingertip calibrate record``
    (a :class:`~fingertip.reference.WrenchSource`).

    Samples are timed by their arrival on this host (``time.monotonic()``, the clock of the
    fingertip's frames), not by their header stamps: the sender's clock may be another
    computer's. The constant part of the network delay is then found with the clock offset
    that ``calibrate record`` estimates from the data, as for any reference.
    """

    def __init__(self, topic: str, transport: str = "dds", *,
                 connect: list[str] | None = None) -> None:
        self.topic = topic
        self.transport = transport
        self.connect = connect
        self.name = f"{transport}:{topic}"
        self._ref: WrenchReference | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._rows: list[tuple[float, tuple[float, ...], tuple[float, ...]]] = []

    def start(self) -> None:
        if self._ref is not None:
            raise RuntimeError(f"{self.name} is already started")
        self._ref = WrenchReference(self.topic, self.transport, connect=self.connect)
        self._stop.clear()
        self._rows = []
        self._thread = threading.Thread(target=self._drain, daemon=True,
                                        name=f"reference-{self.topic}")
        self._thread.start()

    def _drain(self) -> None:
        ref = self._ref
        assert ref is not None
        while not self._stop.is_set():
            got = ref.get_timed(timeout=0.1)
            if got is not None:
                t, m = got
                self._rows.append((t, m.force, m.torque))

    def stop(self) -> ReferenceSamples:
        """Stop listening; the samples received since :meth:`start`."""
        ref, self._ref = self._ref, None
        if ref is None:
            raise RuntimeError(f"{self.name} was not started")
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
        ref.close()
        rows = self._rows
        times = np.array([r[0] for r in rows], float)
        force = np.array([r[1] for r in rows], float).reshape(-1, 3)
        torque = np.array([r[2] for r in rows], float).reshape(-1, 3)
        return ReferenceSamples(times, force, torque, source=self.name,
                                counters={"messages": len(rows), "bad": ref.bad,
                                          "dropped": ref.dropped})
