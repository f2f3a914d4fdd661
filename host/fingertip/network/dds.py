"""ROS 2 over DDS without ROS 2: Cyclone DDS (the ``cyclonedds`` wheel) speaking as rmw does.

What makes a plain DDS endpoint look like a ROS 2 one, and where each rule comes from:

- topic ``/fingertip/index/wrench`` is DDS topic ``rt/fingertip/index/wrench``; a service
  ``/fingertip/index/tare`` is the pair ``rq/fingertip/index/tareRequest`` and
  ``rr/fingertip/index/tareReply`` (ROS 2's topic and service name mangling);
- DDS type names ``pkg::msg::dds_::Type_`` (:func:`.ros_types.dds_type_name`);
- payloads are XCDR1 little-endian CDR, padded with zeros to a multiple of 4 bytes as
  rmw_cyclonedds' ``serdata_rmw::resize`` does: the bytes the recorder writes, plus padding;
- USER_DATA ``typehash=RIHS01_<hex>;`` on every topic's reader and writer (Iron and later);
- service samples: the CDR encapsulation header, then the request id as rmw_cyclonedds
  writes it (``cdds_request_header_t``: uint64 client writer id, int64 sequence number),
  then the request or reply members (checked against rmw_cyclonedds' serdata.hpp/.cpp).

Discovery follows ROS 2's environment: ``ROS_DOMAIN_ID``, ``ROS_AUTOMATIC_DISCOVERY_RANGE``
(``LOCALHOST`` keeps everything on the loopback interface, ``OFF`` finds only
``ROS_STATIC_PEERS``, ``SUBNET`` is the default) and ``ROS_STATIC_PEERS`` (``;``-separated
addresses), and the older ``ROS_LOCALHOST_ONLY=1``. A ``CYCLONEDDS_URI`` set by the user
wins, as it does for rmw_cyclonedds.
"""
from __future__ import annotations

import functools
import logging
import os
import struct
import threading
from collections.abc import Callable, Mapping
from xml.sax.saxutils import escape

from . import require
from .ros_types import TRIGGER_REQUEST, TRIGGER_RESPONSE, dds_type_name, idl_struct, user_data
from .trigger import ServiceStats, TriggerServer, trigger_response_cdr
from ..errors import EXIT_USAGE, NetworkError

log = logging.getLogger(__name__)

SENSOR = "sensor"
"""QoS profile of raw, wrench and audio: rclcpp's ``SensorDataQoS`` (best effort, keep
last 5, volatile)."""
RELIABLE = "reliable"
"""ROS 2's default QoS (reliable, keep last 10, volatile): events and services."""
LATCHED = "latched"
"""info: reliable, keep last 1, transient local, so late subscribers still get it."""

KIND_PROFILE = {"raw": SENSOR, "wrench": SENSOR, "audio": SENSOR, "events": RELIABLE,
                "info": LATCHED}

KEEP_ALL = 0
"""A ``depth`` that keeps every sample (reliable KEEP_ALL history): a service's request
reader and reply writer, as rmw_cyclonedds made them, so that a burst of requests is
neither overwritten before it is taken nor its replies before they are acknowledged."""

MAX_REQUEST_BYTES = 64
"""A std_srvs/Trigger request is 21 bytes (header, request id, one placeholder byte):
anything larger than this is refused without being parsed."""

_REQ_ID = {b"\x00\x01": struct.Struct("<Qq"), b"\x00\x00": struct.Struct(">Qq")}


class DdsError(NetworkError):
    """DDS could not start (bad domain id, configuration...: the user's settings, exit
    status 2) or failed while running (exit status 1): a
    :class:`~fingertip.errors.NetworkError`, a RuntimeError."""


def ros_topic(topic: str) -> str:
    """``/a/b`` -> ``rt/a/b``."""
    return "rt" + topic


def discovery_config(env: Mapping[str, str] | None = None) -> str | None:
    """A Cyclone DDS configuration for ROS 2's discovery variables, or None to keep
    Cyclone's defaults (or the user's ``CYCLONEDDS_URI``)."""
    env = os.environ if env is None else env
    if env.get("CYCLONEDDS_URI"):
        return None
    scope = env.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "").strip().upper()
    if not scope and env.get("ROS_LOCALHOST_ONLY", "") == "1":
        scope = "LOCALHOST"
    scope = scope or "SUBNET"
    if scope not in ("SUBNET", "LOCALHOST", "OFF", "SYSTEM_DEFAULT"):
        raise DdsError(f"ROS_AUTOMATIC_DISCOVERY_RANGE={scope!r}: use SUBNET, LOCALHOST, OFF "
                       "or SYSTEM_DEFAULT", exit_code=EXIT_USAGE)
    peers = [p.strip() for p in env.get("ROS_STATIC_PEERS", "").split(";") if p.strip()]
    if scope in ("SUBNET", "SYSTEM_DEFAULT") and not peers:
        return None
    general, discovery = [], []
    if scope == "LOCALHOST":
        general.append('<Interfaces><NetworkInterface address="127.0.0.1"/></Interfaces>')
        peers = ["127.0.0.1", *peers]
    if scope in ("LOCALHOST", "OFF"):
        general.append("<AllowMulticast>false</AllowMulticast>")
        discovery.append("<ParticipantIndex>auto</ParticipantIndex>"
                         "<MaxAutoParticipantIndex>64</MaxAutoParticipantIndex>")
    if peers:
        discovery.append("<Peers>" + "".join(f'<Peer address="{escape(p, {chr(34): "&quot;"})}"/>'
                                             for p in peers) + "</Peers>")
    return ('<CycloneDDS><Domain id="any"><General>' + "".join(general) + "</General>"
            "<Discovery>" + "".join(discovery) + "</Discovery></Domain></CycloneDDS>")


def domain_id(env: Mapping[str, str] | None = None) -> int:
    """``ROS_DOMAIN_ID`` (0 when unset)."""
    env = os.environ if env is None else env
    raw = env.get("ROS_DOMAIN_ID", "").strip() or "0"
    try:
        d = int(raw)
    except ValueError:
        raise DdsError(f"ROS_DOMAIN_ID={raw!r} is not a number (0-232)",
                       exit_code=EXIT_USAGE) from None
    if not 0 <= d <= 232:
        raise DdsError(f"ROS_DOMAIN_ID={d} is out of range (0-232)", exit_code=EXIT_USAGE)
    return d


def pad4(data: bytes) -> bytes:
    """Zero padding to a multiple of 4 bytes, as rmw_cyclonedds sends payloads."""
    n = -len(data) % 4
    return data + b"\0" * n if n else data


class DdsNode:
    """One DDS participant with ROS 2-compatible writers, readers and services."""

    def __init__(self, env: Mapping[str, str] | None = None) -> None:
        self._dds = require("cyclonedds", "ROS 2 over DDS (--transport dds)")
        from cyclonedds.core import InstanceState, Policy, Qos, SampleState, ViewState, WaitSet
        from cyclonedds.domain import Domain, DomainParticipant

        self._Qos = Qos
        self._mask = SampleState.Any | ViewState.Any | InstanceState.Any
        self.domain_id = domain_id(env)
        cfg = discovery_config(env)
        try:
            # The domain must outlive the participant: keep a reference.
            self._domain = Domain(self.domain_id, cfg) if cfg else None
            # rmw marks every participant with its security enclave ("/" by default).
            self.participant = DomainParticipant(
                self.domain_id, qos=Qos(Policy.Userdata(b"enclave=/;")))
        except Exception as e:
            # the settings the user gave (domain, discovery, CYCLONEDDS_URI): exit 2
            raise DdsError(f"cannot start DDS on domain {self.domain_id}: {e}",
                           exit_code=EXIT_USAGE) from e
        self._topics: dict[str, object] = {}
        self._writers: list = []
        self._reader_entities: list = []
        self._graph = None
        self._readers: dict[object, Callable[[bytes], None]] = {}
        self._waitset = WaitSet(self.participant)
        self._conds: dict[object, object] = {}
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    # --- QoS --------------------------------------------------------------------------------

    def qos(self, profile: str, type_name: str | None, depth: int | None = None):
        from cyclonedds.core import Policy
        from cyclonedds.util import duration

        if profile == SENSOR:
            p = [Policy.Reliability.BestEffort, Policy.History.KeepLast(5),
                 Policy.Durability.Volatile]
        elif profile == RELIABLE:
            p = [Policy.Reliability.Reliable(duration(milliseconds=100)),
                 Policy.History.KeepLast(10), Policy.Durability.Volatile]
        elif profile == LATCHED:
            p = [Policy.Reliability.Reliable(duration(milliseconds=100)),
                 Policy.History.KeepLast(1), Policy.Durability.TransientLocal]
        else:
            raise ValueError(f"unknown QoS profile {profile!r}")
        if depth == KEEP_ALL:  # nothing overwritten: a full reader pushes back instead
            p[1] = Policy.History.KeepAll
        elif depth is not None:  # a reader that must not lose what it is slow to take
            p[1] = Policy.History.KeepLast(depth)
        if type_name is not None:
            p.append(Policy.Userdata(user_data(type_name)))
        return self._Qos(*p)

    def _topic(self, dds_name: str, type_name: str):
        from cyclonedds.topic import Topic

        t = self._topics.get(dds_name)
        if t is None:
            t = Topic(self.participant, dds_name, idl_struct(type_name))
            self._topics[dds_name] = t
        return t

    # --- publishing ---------------------------------------------------------------------------

    def writer(self, dds_name: str, type_name: str, profile: str,
               hashed: bool = True, depth: int | None = None) -> Callable[[bytes], None]:
        """A function that publishes ready CDR bytes on DDS topic ``dds_name``."""
        from cyclonedds._clayer import ddspy_write
        from cyclonedds.pub import DataWriter

        w = DataWriter(self.participant, self._topic(dds_name, type_name),
                       self.qos(profile, type_name if hashed else None, depth))
        self._writers.append(w)
        ref = w._ref

        def write(data: bytes) -> None:
            ret = ddspy_write(ref, pad4(data))
            if ret < 0:
                raise DdsError(f"writing on {dds_name} failed (DDS error {ret})")
        write.writer = w  # type: ignore[attr-defined]
        return write

    # --- subscribing ----------------------------------------------------------------------------

    def reader(self, dds_name: str, type_name: str, profile: str,
               on_data: Callable[[bytes], None], hashed: bool = True,
               depth: int | None = None):
        """Call ``on_data(cdr_bytes)`` (on the node's reader thread) for every sample;
        returns the DDS reader (its lost and rejected samples: :func:`samples_dropped`)."""
        from cyclonedds.core import ReadCondition
        from cyclonedds.sub import DataReader

        r = DataReader(self.participant, self._topic(dds_name, type_name),
                       self.qos(profile, type_name if hashed else None, depth))
        cond = ReadCondition(r, self._mask)
        self._reader_entities.append(r)
        with self._lock:
            self._readers[r] = on_data
            self._conds[r] = cond
            self._waitset.attach(cond)
        if self._thread is None:
            self._thread = threading.Thread(target=self._read_loop, daemon=True,
                                            name="dds-readers")
            self._thread.start()
        return r

    def _read_loop(self) -> None:
        from cyclonedds._clayer import ddspy_take
        from cyclonedds.util import duration

        while not self._stop.is_set():
            waitset = self._waitset
            if waitset is None:  # closed while this thread was late to stop
                return
            waitset.wait(duration(milliseconds=100))
            with self._lock:
                items = list(self._readers.items())
            for r, fn in items:
                while True:
                    got = ddspy_take(r._ref, self._mask, 64)
                    if isinstance(got, int) or not got:
                        break
                    for data, info in got:
                        if not info.valid_data:
                            continue
                        try:
                            fn(data)
                        except Exception:  # one bad sample or handler must not stop reading
                            log.exception("handling a sample of %s failed",
                                          r.topic.get_name())

    # --- the ROS graph --------------------------------------------------------------------------

    def announce(self, node_name: str = "fingertip", namespace: str = "/") -> None:
        """Tell ROS 2 tools (``ros2 node list``, ``ros2 topic info -v``) that one node owns
        this participant's readers and writers: ``ros_discovery_info``, as rmw_dds_common
        writes it since Jazzy (16-byte GIDs, the DDS GUIDs). Call again after adding
        readers or writers; late joiners get the latest (transient local)."""
        try:
            self._announce(node_name, namespace)
        except Exception as e:  # the graph is a courtesy to ROS tools: never fatal
            log.warning("could not announce the node on ros_discovery_info: %s", e)

    def _announce(self, node_name: str, namespace: str) -> None:
        from cyclonedds.pub import DataWriter

        from .ros_types import GID, NODE_ENTITIES, PARTICIPANT_ENTITIES

        Gid, Node = idl_struct(GID), idl_struct(NODE_ENTITIES)
        Info = idl_struct(PARTICIPANT_ENTITIES)
        if self._graph is None:
            self._graph = DataWriter(
                self.participant, self._topic("ros_discovery_info", PARTICIPANT_ENTITIES),
                self.qos(LATCHED, PARTICIPANT_ENTITIES))

        def gid(entity) -> object:
            return Gid(data=list(entity.guid.bytes))
        node = Node(node_namespace=namespace, node_name=node_name,
                    reader_gid_seq=[gid(r) for r in self._reader_entities],
                    writer_gid_seq=[gid(w) for w in self._writers])
        self._graph.write(Info(gid=gid(self.participant), node_entities_info_seq=[node]))

    # --- services -------------------------------------------------------------------------------

    def trigger_service(self, service: str, handler: Callable[[], tuple[bool, str]],
                        stats: ServiceStats | None = None) -> ServiceStats:
        """Serve ``std_srvs/srv/Trigger`` at ROS 2 service ``service`` (``/a/b``).

        ``handler()`` runs on a worker thread (a tare takes a while) and returns
        ``(success, message)``. Malformed or oversized requests are refused and counted;
        no request can stop the node. Every request that reaches the reader is answered
        (done, busy or refused); requests DDS lost or rejected on the way (a client's
        keep-last writer overwriting what it had not delivered) are counted as dropped.
        """
        # KEEP_ALL both ways: with ROS's default keep-last 10, a burst of requests was
        # overwritten in the reader's history before the reader thread took it, and the
        # replies in the writer's before the client acknowledged them (200 requests: 16
        # reached the service, 13 replies reached the client, nothing counted the rest).
        reply = self.writer(f"rr{service}Reply", TRIGGER_RESPONSE, RELIABLE, hashed=False,
                            depth=KEEP_ALL)
        server = TriggerServer(service, handler, stats)

        def on_request(data: bytes) -> None:
            server.stats.requests += 1
            req_id, reason, text = check_trigger_request(data)

            def answer(ok: bool, message: str, _id=req_id) -> None:
                reply(encode_trigger_reply(_id, ok, message))
            if reason is not None:
                server.refuse(reason, text, answer if req_id is not None else None)
                return
            server.request(answer)

        r = self.reader(f"rq{service}Request", TRIGGER_REQUEST, RELIABLE, on_request,
                        hashed=False, depth=KEEP_ALL)
        server.stats.dropped_by = lambda: samples_dropped(r)
        return server.stats

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2)
        # Deleting the participant deletes every entity it owns, once nothing refers to it:
        # drop every entity (each holds the participant) and the domain (its settings). A
        # closed node that is still referenced (a caller's variable, a traceback) otherwise
        # keeps them, and the next node on the domain with other settings cannot start.
        with self._lock:
            self._readers.clear()
        self._writers.clear()
        self._reader_entities.clear()
        self._conds.clear()
        self._topics.clear()
        self._graph = None
        self._waitset = None
        self.participant = None
        self._domain = None


class DdsTransport:
    """The feed's transport over DDS: one writer per topic, QoS by :data:`KIND_PROFILE`."""

    def __init__(self, node: DdsNode | None = None) -> None:
        from ..record import schemas as S
        from .feed import ENCODERS

        self.node = node or DdsNode()
        self._S = S
        # The hot kinds come out of their encoder already padded as rmw_cyclonedds sends
        # them, so the writer's pad4 has nothing left to copy.
        self._encoders = dict(ENCODERS)
        for kind, enc in (("raw", S.encode_raw), ("wrench", S.encode_wrench),
                          ("audio", S.encode_audio)):
            self._encoders[kind] = functools.partial(enc, padded=True)
        self._writers: dict[tuple[str, str], Callable[[bytes], None]] = {}
        self.services: dict[str, ServiceStats] = {}
        self._clock: Callable[[bytes], None] | None = None
        self._diagnostics: Callable[[bytes], None] | None = None

    def add_fingertip(self, name: str, info: dict | None = None) -> None:
        """Writers for fingertip ``name`` (``info`` goes out on its topic, not here)."""
        S = self._S
        for kind, schema in S.TOPIC_KINDS.items():
            self._writers[name, kind] = self.node.writer(
                ros_topic(S.topic(name, kind)), schema, KIND_PROFILE[kind])
        self.node.announce()

    def publish(self, name: str, kind: str, msg) -> None:
        self._writers[name, kind](self._encoders[kind](msg))

    def wait_subscribers(self, n: int, timeout: float) -> bool:
        """Wait until every raw topic has ``n`` matched readers; False at the timeout."""
        import time

        deadline = time.monotonic() + timeout
        raws = [w.writer for (_, kind), w in self._writers.items()  # type: ignore[attr-defined]
                if kind == "raw"]
        while time.monotonic() < deadline:
            if all(len(w.get_matched_subscriptions()) >= n for w in raws):
                return True
            time.sleep(0.05)
        return False

    def declare_clock(self) -> None:
        """The ``/clock`` writer, before the first tick: subscribers find it while the
        publisher waits for them, and do not miss the replay's first ticks."""
        from .ros_types import CLOCK

        if self._clock is None:
            self._clock = self.node.writer("rt/clock", CLOCK, SENSOR)
            self.node.announce()

    def publish_clock(self, ns: int) -> None:
        """``/clock`` (rosgraph_msgs/msg/Clock, rclcpp's clock QoS: best effort, keep last
        1), for subscribers that run with ``use_sim_time``."""
        self.declare_clock()
        assert self._clock is not None
        sec, nsec = divmod(int(ns), 1_000_000_000)
        self._clock(b"\x00\x01\x00\x00" + struct.pack("<iI", sec, nsec))

    def serve_tare(self, name: str, handler: Callable[[], tuple[bool, str]]) -> ServiceStats:
        """``std_srvs/srv/Trigger`` at ``/fingertip/<name>/tare``."""
        service = f"/fingertip/{name}/tare"
        self.services[service] = self.node.trigger_service(service, handler)
        self.node.announce()
        return self.services[service]

    def publish_diagnostics(self, data: bytes) -> None:
        """A ``diagnostic_msgs/msg/DiagnosticArray`` (CDR) on ``/diagnostics``, with the QoS
        of diagnostic_updater's publisher (reliable, volatile, keep last 1)."""
        from .diagnostics import DIAGNOSTIC_ARRAY, TOPIC

        if self._diagnostics is None:
            self._diagnostics = self.node.writer(ros_topic(TOPIC), DIAGNOSTIC_ARRAY, RELIABLE,
                                                 depth=1)
            self.node.announce()
        self._diagnostics(data)

    def close(self) -> None:
        self._writers.clear()
        self._clock = self._diagnostics = None
        self.node.close()


def subscribe(node: DdsNode, names: list[str], on_message: Callable[[str, str, bytes], None],
              kinds: tuple[str, ...] | None = None) -> None:
    """Call ``on_message(name, kind, cdr_bytes)`` for every message of fingertips
    ``names`` (each reader with its topic's QoS and a deep history, so that a slow moment
    loses nothing)."""
    from ..record import schemas as S

    for name in names:
        for kind in kinds or tuple(S.TOPIC_KINDS):
            node.reader(ros_topic(S.topic(name, kind)), S.TOPIC_KINDS[kind], KIND_PROFILE[kind],
                        lambda data, _n=name, _k=kind: on_message(_n, _k, data),
                        depth=1000 if kind != "info" else None)
    node.announce("fingertip_recorder")


def samples_dropped(reader) -> int:
    """Samples a DDS reader never got (lost: the writer no longer had them) or refused
    (rejected: its resource limits)."""
    try:
        return (reader.get_sample_lost_status().total_count
                + reader.get_sample_rejected_status().total_count)
    except Exception:  # the participant is gone (closed): nothing more was dropped
        return 0


def check_trigger_request(data: bytes) -> tuple[tuple[int, int] | None, str | None, str]:
    """``(request id or None, reason for refusing or None, message)`` of a Trigger request.

    Cyclone itself drops samples that do not deserialise as the topic's type before they
    reach us; this is the second line, for what it lets through (trailing bytes) and for
    transports that check nothing.
    """
    req_id = parse_request_id(data)
    if req_id is None:
        return None, "malformed", f"{len(data)} bytes without a request id"
    if len(data) > MAX_REQUEST_BYTES:
        return req_id, "oversized", (f"request of {len(data)} bytes is larger than a "
                                     f"std_srvs/srv/Trigger request (at most "
                                     f"{MAX_REQUEST_BYTES})")
    if len(data) < 21:
        return req_id, "malformed", ("request has no body (a std_srvs/srv/Trigger request "
                                     "is 21 bytes)")
    return req_id, None, ""


def parse_request_id(data: bytes) -> tuple[int, int] | None:
    """``(client id, sequence number)`` of a service sample, or None if it has none."""
    s = _REQ_ID.get(bytes(data[:2]))
    if s is None or len(data) < 4 + s.size:
        return None
    return s.unpack_from(data, 4)


def encode_request(req_id: tuple[int, int], body: bytes = b"\0") -> bytes:
    """A service request sample: CDR header, request id, then the request's members (a
    Trigger request: its one placeholder byte)."""
    return pad4(b"\x00\x01\x00\x00" + _REQ_ID[b"\x00\x01"].pack(*req_id) + body)


def encode_trigger_reply(req_id: tuple[int, int], success: bool, message: str) -> bytes:
    """A std_srvs/srv/Trigger reply sample (little-endian CDR)."""
    return pad4(b"\x00\x01\x00\x00" + _REQ_ID[b"\x00\x01"].pack(*req_id)
                + trigger_response_cdr(success, message))


def decode_trigger_reply(data: bytes) -> tuple[tuple[int, int], bool, str]:
    """``(request id, success, message)`` of a Trigger reply sample."""
    req_id = parse_request_id(data)
    if req_id is None:
        raise ValueError("not a service reply")
    pos = 20
    success = bool(data[pos])
    (n,) = struct.unpack_from("<I", data, pos + 4)
    text = bytes(data[pos + 8:pos + 8 + n - 1]).decode("utf-8")
    return req_id, success, text


__all__ = ["DdsError", "DdsNode", "KIND_PROFILE", "ServiceStats", "discovery_config",
           "domain_id", "dds_type_name", "ros_topic"]
