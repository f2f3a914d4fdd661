"""ROS 2 over Zenoh, as rmw_zenoh writes it (the ``eclipse-zenoh`` wheel, the ``zenoh`` extra).

Followed: ros2/rmw_zenoh at commit 534747d (attachment_helpers.cpp) and 3411fde
(liveliness_utils.cpp), the format of the rmw_zenoh releases whose attachment has no keys:

- data key expression ``<domain>/<topic without leading slash>/<DDS type name>/<RIHS01 hash>``,
  e.g. ``0/fingertip/index/wrench/geometry_msgs::msg::dds_::WrenchStamped_/RIHS01_8dc3...``;
- liveliness tokens ``@ros2_lv/<domain>/<zid>/<node id>/<entity id>/<NN|MP|MS>/<enclave>/
  <namespace>/<node>[/<topic>/<type>/<hash>/<qos>]``, every name with ``/`` written ``%``,
  QoS as ``reliability:durability:history,depth:deadline:lifespan:liveliness,lease`` with
  each field left empty when it is rmw's default;
- each sample's attachment, zenoh-ext serialised: int64 sequence number, int64 source
  timestamp (ns), the 16-byte publisher GID as a length-prefixed byte string (33 bytes);
- payload: the message's CDR bytes (what the recorder writes);
- transient local (``info``): an advanced publisher with a cache of ``depth`` samples and
  publisher detection, read by an advanced subscriber that detects late publishers and
  queries their history (rmw_zenoh's publisher and subscription data, same releases);
- a service (``std_srvs/srv/Trigger`` tare): a complete queryable on the key expression
  ``<domain>/<service>/std_srvs::srv::dds_::Trigger_/<service's RIHS01>``; the request is
  the query's payload (CDR) with the client's attachment, the reply carries the request's
  sequence number and the client's GID back (rmw_service_data.cpp), token kind ``SS``.

rmw_zenoh derives GIDs with XXH3-128 of the token; ours are the first 16 bytes of its SHA-256
(a subscriber only copies the GID into the message info).
"""
from __future__ import annotations

import hashlib
import itertools
import logging
import struct
import threading
import time
from collections.abc import Callable

from ..errors import EXIT_USAGE, NetworkError
from ..record import schemas as S
from . import require
from .dds import MAX_REQUEST_BYTES, domain_id
from .ros_types import TRIGGER, dds_type_name, type_hash
from .trigger import ServiceStats, TriggerServer, trigger_response_cdr

log = logging.getLogger(__name__)

# rmw's enum values: reliability 1 reliable, 2 best effort; durability 1 transient local,
# 2 volatile; history 1 keep last. Default (omitted): reliable, volatile, keep last 10.
KIND_QOS = {"raw": "2::,5:,:,:,,", "wrench": "2::,5:,:,:,,", "audio": "2::,5:,:,:,,",
            "events": "::,:,:,:,,", "info": ":1:,1:,:,:,,"}
DIAGNOSTICS_QOS = "::,1:,:,:,,"  # /diagnostics: reliable, volatile, keep last 1
SERVICE_QOS = "::,:,:,:,,"  # rmw's services default: reliable, volatile, keep last 10
TRANSIENT_LOCAL_KINDS = ("info",)
NODE = "fingertip"


def mangle(name: str) -> str:
    return name.replace("/", "%")


def key_expr(domain: int, topic: str, schema: str) -> str:
    """rmw_zenoh's data key expression of ``topic`` (``/a/b``) of type ``schema``."""
    return f"{domain}/{topic.strip('/')}/{dds_type_name(schema)}/{type_hash(schema)}"


def token(domain: int, zid: str, nid: int, eid: int, kind: str, topic: str | None = None,
          schema: str | None = None, qos: str = "") -> str:
    """A liveliness token: ``kind`` NN (node), MP (publisher), MS (subscription) or SS
    (service server)."""
    parts = ["@ros2_lv", str(domain), zid, str(nid), str(eid), kind, "%", "%", NODE]
    if topic is not None and schema is not None:
        parts += [mangle(topic), dds_type_name(schema), type_hash(schema), qos]
    return "/".join(parts)


def gid(token_expr: str) -> bytes:
    return hashlib.sha256(token_expr.encode()).digest()[:16]


def attachment(seq: int, timestamp_ns: int, source_gid: bytes) -> bytes:
    """rmw_zenoh's attachment (33 bytes)."""
    return struct.pack("<qqB", seq, timestamp_ns, len(source_gid)) + source_gid


def parse_attachment(data: bytes) -> tuple[int, int, bytes]:
    if len(data) != 33 or data[16] != 16:
        raise ValueError(f"not an rmw_zenoh attachment ({len(data)} bytes)")
    seq, ts = struct.unpack_from("<qq", data)
    return seq, ts, bytes(data[17:33])


class ZenohNode:
    """A Zenoh session that looks like one rmw_zenoh node named ``fingertip``.

    ``connect``: endpoints to connect to (a router such as ``tcp/192.168.1.2:7447``, or a
    peer); ``listen``: endpoints to listen on. With neither, peer mode with Zenoh's
    multicast scouting (the local network).
    """

    def __init__(self, connect: list[str] | None = None, listen: list[str] | None = None
                 ) -> None:
        self.z = require("zenoh", "ROS 2 over Zenoh (--transport zenoh)")
        import json

        try:
            conf = self.z.Config()
            conf.insert_json5("mode", '"peer"')
            if connect:
                conf.insert_json5("connect/endpoints", json.dumps(connect))
                # A router or peer that is not up yet (or restarts) is found again within a
                # second, not after Zenoh's default back-off of up to 4 s.
                conf.insert_json5("connect/retry", '{"period_init_ms": 200, "period_max_ms": '
                                                   '1000, "period_increase_factor": 1.5}')
            if listen:
                conf.insert_json5("listen/endpoints", json.dumps(listen))
            if connect or listen:  # explicit endpoints: no need to shout on the network
                conf.insert_json5("scouting/multicast/enabled", "false")
            self.session = self.z.open(conf)
        except Exception as e:  # the endpoints the user gave, or the network they name: 2
            raise NetworkError(f"cannot start Zenoh ({e})", exit_code=EXIT_USAGE) from e
        self.domain = domain_id()
        self.zid = str(self.session.zid())
        self._ids = itertools.count(1)
        self._tokens = [self.session.liveliness().declare_token(
            token(self.domain, self.zid, 0, 0, "NN"))]
        self._subs: list = []
        self._pubs: list = []
        self._queryables: list = []

    def publisher(self, topic: str, schema: str, qos: str, transient_local: bool = False
                  ) -> Callable[[bytes], None]:
        """``transient_local``: keep the last sample for subscribers that join later, as
        rmw_zenoh does for TRANSIENT_LOCAL (depth 1: our only such topic is ``info``)."""
        eid = next(self._ids)
        tok = token(self.domain, self.zid, 0, eid, "MP", topic, schema, qos)
        self._tokens.append(self.session.liveliness().declare_token(tok))
        best_effort = qos.startswith("2")
        opts = dict(reliability=(self.z.Reliability.BEST_EFFORT if best_effort
                                 else self.z.Reliability.RELIABLE),
                    congestion_control=(self.z.CongestionControl.DROP if best_effort
                                        else self.z.CongestionControl.BLOCK))
        ke = key_expr(self.domain, topic, schema)
        if transient_local:
            from zenoh import ext

            pub = ext.declare_advanced_publisher(
                self.session, ke, cache=ext.CacheConfig(1), publisher_detection=True,
                sample_miss_detection=ext.MissDetectionConfig(sporadic_heartbeat=1.0),
                **opts)
        else:
            pub = self.session.declare_publisher(ke, **opts)
        self._pubs.append(pub)
        source_gid = gid(tok)
        seq = itertools.count(1)
        lock = threading.Lock()

        def put(data: bytes) -> None:
            with lock:  # sequence numbers in the order of the samples
                pub.put(data, attachment=attachment(next(seq), time.time_ns(), source_gid))
        put.publisher = pub  # type: ignore[attr-defined]
        return put

    def subscribe(self, names: list[str], on_message: Callable[[str, str, bytes], None],
                  on_attachment: Callable[[str, str, tuple[int, int, bytes]], None] | None
                  = None, kinds: tuple[str, ...] | None = None) -> None:
        """``on_message(name, kind, cdr_bytes)`` for every message of fingertips ``names``."""
        tokens = []
        for name in names:
            for kind in kinds or tuple(S.TOPIC_KINDS):
                schema = S.TOPIC_KINDS[kind]
                topic = S.topic(name, kind)
                tokens.append(token(self.domain, self.zid, 0, next(self._ids), "MS", topic,
                                    schema, KIND_QOS[kind]))

                def handler(sample, _n=name, _k=kind) -> None:
                    if on_attachment is not None and sample.attachment is not None:
                        on_attachment(_n, _k, parse_attachment(sample.attachment.to_bytes()))
                    on_message(_n, _k, sample.payload.to_bytes())
                ke = key_expr(self.domain, topic, schema)
                if kind in TRANSIENT_LOCAL_KINDS:  # late joiner: ask for the history
                    from zenoh import ext

                    self._subs.append(ext.declare_advanced_subscriber(
                        self.session, ke, handler,
                        history=ext.HistoryConfig(detect_late_publishers=True),
                        recovery=ext.RecoveryConfig(heartbeat=True),
                        subscriber_detection=True))
                else:
                    self._subs.append(self.session.declare_subscriber(ke, handler))
        # Tokens last: a publisher that waits for them finds every subscriber ready.
        for tok in tokens:
            self._tokens.append(self.session.liveliness().declare_token(tok))

    def trigger_service(self, service: str, handler: Callable[[], tuple[bool, str]],
                        stats: ServiceStats | None = None) -> ServiceStats:
        """Serve ``std_srvs/srv/Trigger`` at ROS 2 service ``service`` (``/a/b``), as
        rmw_zenoh serves services: ``handler()`` runs on a worker thread and returns
        ``(success, message)``; malformed, oversized and concurrent requests are refused
        and counted."""
        server = TriggerServer(service, handler, stats)
        ke = key_expr(self.domain, service, TRIGGER)

        def on_query(query) -> None:
            server.stats.requests += 1
            payload = b"" if query.payload is None else query.payload.to_bytes()
            try:
                seq, _, client = parse_attachment(
                    b"" if query.attachment is None else query.attachment.to_bytes())
            except ValueError:
                seq, client = None, b""

            def answer(ok: bool, message: str) -> None:
                try:
                    att = (None if seq is None
                           else attachment(seq, time.time_ns(), client))
                    query.reply(ke, b"\x00\x01\x00\x00" + trigger_response_cdr(ok, message),
                                attachment=att)
                finally:
                    query.drop()  # the reply is final: tell the client now
            reason, text = check_trigger_query(payload, seq is not None)
            if reason is not None:
                server.refuse(reason, text, answer)
                return
            server.request(answer)
        self._queryables.append(self.session.declare_queryable(ke, on_query, complete=True))
        self._tokens.append(self.session.liveliness().declare_token(
            token(self.domain, self.zid, 0, next(self._ids), "SS", service, TRIGGER,
                  SERVICE_QOS)))
        return server.stats

    def close(self) -> None:
        for t in self._tokens:
            t.undeclare()
        self._tokens.clear()
        self.session.close()


def check_trigger_query(payload: bytes, has_attachment: bool) -> tuple[str | None, str]:
    """``(reason for refusing or None, message)`` of a Trigger request over Zenoh (CDR
    header and one placeholder byte: 5 bytes)."""
    if not has_attachment:
        return "malformed", "request without an rmw_zenoh attachment (33 bytes)"
    if len(payload) > MAX_REQUEST_BYTES:
        return "oversized", (f"request of {len(payload)} bytes is larger than a "
                             f"std_srvs/srv/Trigger request (at most {MAX_REQUEST_BYTES})")
    if len(payload) < 5 or payload[:2] not in (b"\x00\x00", b"\x00\x01"):
        return "malformed", ("request is not a CDR std_srvs/srv/Trigger request (5 bytes: "
                             "header and one placeholder byte)")
    return None, ""


class ZenohTransport:
    """The feed's transport over Zenoh."""

    def __init__(self, connect: list[str] | None = None, listen: list[str] | None = None
                 ) -> None:
        from .feed import ENCODERS

        self.node = ZenohNode(connect, listen)
        self._encoders = ENCODERS
        self._pubs: dict[tuple[str, str], Callable[[bytes], None]] = {}
        self.services: dict[str, ServiceStats] = {}
        self._diagnostics: Callable[[bytes], None] | None = None

    def add_fingertip(self, name: str, info: dict | None = None) -> None:
        """Publishers for fingertip ``name`` (``info`` goes out on its topic, not here)."""
        for kind, schema in S.TOPIC_KINDS.items():
            self._pubs[name, kind] = self.node.publisher(
                S.topic(name, kind), schema, KIND_QOS[kind],
                transient_local=kind in TRANSIENT_LOCAL_KINDS)

    def serve_tare(self, name: str, handler: Callable[[], tuple[bool, str]]) -> ServiceStats:
        """``std_srvs/srv/Trigger`` at ``/fingertip/<name>/tare``."""
        service = f"/fingertip/{name}/tare"
        self.services[service] = self.node.trigger_service(service, handler)
        return self.services[service]

    def publish(self, name: str, kind: str, msg) -> None:
        self._pubs[name, kind](self._encoders[kind](msg))

    def publish_diagnostics(self, data: bytes) -> None:
        """A ``diagnostic_msgs/msg/DiagnosticArray`` (CDR) on ``/diagnostics`` (reliable,
        volatile, keep last 1, as diagnostic_updater publishes it)."""
        from .diagnostics import DIAGNOSTIC_ARRAY, TOPIC

        if self._diagnostics is None:
            self._diagnostics = self.node.publisher(TOPIC, DIAGNOSTIC_ARRAY, DIAGNOSTICS_QOS)
        self._diagnostics(data)

    def wait_subscribers(self, n: int, timeout: float) -> bool:
        """Wait for ``n`` subscription tokens (MS) on every raw topic."""
        deadline = time.monotonic() + timeout
        raws = {k[0] for k in self._pubs if k[1] == "raw"}
        while time.monotonic() < deadline:
            ok = True
            for name in raws:
                sel = (f"@ros2_lv/{self.node.domain}/*/*/*/MS/**/"
                       f"{mangle(S.topic(name, 'raw'))}/**")
                replies = list(self.node.session.liveliness().get(sel, timeout=1.0))
                if len(replies) < n:
                    ok = False
            if ok:
                return True
            time.sleep(0.1)
        return False

    def close(self) -> None:
        self.node.close()
