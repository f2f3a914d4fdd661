"""Over Zenoh, in another process on loopback: the tare service as rmw_zenoh serves
services (a queryable keyed by the service type's RIHS01 hash, request and reply carrying
rmw_zenoh's attachment), bad requests refused, and `info` for a subscriber that joins
after it was published (rmw_zenoh's transient-local emulation)."""
from __future__ import annotations

import contextlib
import json
import re
import signal
import threading
import time

import pytest

from fingertip.network import zenoh as Z
from fingertip.network.ros_types import TRIGGER, type_hash
from fingertip.record import schemas as S

from .conftest import start, wait_line
from .test_zenoh_stream import free_port

pytest.importorskip("zenoh")

SERVICE = "/fingertip/index/tare"


def test_service_type_hashes_match_ros2():
    # Published by other implementations of REP 2011 (std_srvs as of Jazzy and Kilted).
    assert type_hash(TRIGGER) == ("RIHS01_eeff2cd6fa5ad9d27cdf4dec64818317839b62f212a91e6b"
                                  "5304b634b2062c5f")
    assert type_hash(TRIGGER + "_Request") == ("RIHS01_d010825374ce8918e72bfd826c82603e60f4"
                                               "5419e932ea976f807b74a863a199")
    assert type_hash(TRIGGER + "_Event") == ("RIHS01_ec4a1d26b0575e61906890342aba9523a2360e"
                                             "9845857c5590fa6e23bc39e1c2")


def call(node: Z.ZenohNode, payload: bytes, att: bytes | None, timeout: float = 10.0):
    """One query on the service's key expression: ``(payload, attachment)`` of the reply."""
    ke = Z.key_expr(node.domain, SERVICE, TRIGGER)
    replies = list(node.session.get(ke, payload=payload, attachment=att, timeout=timeout))
    assert len(replies) == 1, f"{len(replies)} replies"
    ok = replies[0].ok
    assert ok is not None, replies[0].err
    return (ok.payload.to_bytes(),
            None if ok.attachment is None else ok.attachment.to_bytes())


@contextlib.contextmanager
def zenoh_publisher(out: dict, join_after: float = 1.0):
    """``fingertip publish --virtual 1 --name index`` over Zenoh in another process, and a
    node that connects to it ``join_after`` seconds after it started publishing; once both
    are stopped (the publisher by SIGINT), ``out["err"]`` holds the publisher's stderr."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    pub = start("publish", "--virtual", "1", "--name", "index", "--transport", "zenoh",
                "--zenoh-listen", endpoint, "--duration", "60")
    node = None
    try:
        wait_line(pub, "publishing")
        time.sleep(join_after)
        node = Z.ZenohNode(connect=[endpoint])
        yield node
    finally:
        if node is not None:
            node.close()
        pub.send_signal(signal.SIGINT)
        _, out["err"] = pub.communicate(timeout=30)


def response(payload: bytes) -> tuple[bool, str]:
    assert payload[:4] == b"\x00\x01\x00\x00"
    n = int.from_bytes(payload[8:12], "little")
    return bool(payload[4]), payload[12:12 + n - 1].decode()


@pytest.mark.slow
def test_tare_service_and_late_info_over_zenoh():
    out: dict = {}
    # info went out at the start: this subscriber joins late
    with zenoh_publisher(out, join_after=1.5) as node:
        infos: list[bytes] = []
        got = threading.Event()

        def on_info(name: str, kind: str, data: bytes) -> None:
            infos.append(data)
            got.set()
        node.subscribe(["index"], on_info, kinds=("info",))
        assert got.wait(15), "a late subscriber did not get info"
        info = json.loads(S.decode_string(infos[0]))
        assert info["name"] == "index"

        sel = f"@ros2_lv/{node.domain}/*/*/*/SS/%/%/fingertip/{Z.mangle(SERVICE)}/**"
        tokens = [str(r.ok.key_expr) for r in node.session.liveliness().get(sel)
                  if r.ok is not None]
        assert len(tokens) == 1 and tokens[0].endswith(
            f"/std_srvs::srv::dds_::Trigger_/{type_hash(TRIGGER)}/{Z.SERVICE_QOS}"), tokens

        gid = bytes(range(16))
        data, att = call(node, b"\x00\x01\x00\x00\x00", Z.attachment(7, time.time_ns(), gid))
        ok, text = response(data)
        assert ok and text.startswith("tare offsets: "), text
        seq, _, back = Z.parse_attachment(att)
        assert (seq, back) == (7, gid)  # what a client matches its reply by

        data, att = call(node, b"\x00\x01\x00\x00\x00", None)  # no attachment
        assert response(data) == (False, "request without an rmw_zenoh attachment (33 "
                                         "bytes)")
        assert att is None
        data, att = call(node, bytes(200), Z.attachment(8, time.time_ns(), gid))
        ok, text = response(data)
        assert not ok and "larger than" in text
        assert Z.parse_attachment(att)[0] == 8
    err = out["err"]
    m = re.search(r"/fingertip/index/tare: (\d+) requests, (\d+) answered, (\d+) refused", err)
    assert m and m.groups() == ("3", "1", "2"), err[-1500:]


def test_a_burst_of_200_tare_requests_over_zenoh_is_answered_or_counted():
    """200 queries at once: each gets its reply (one tare, the rest busy), by its own
    sequence number, and the publisher's count agrees."""
    out: dict = {}
    with zenoh_publisher(out) as node:
        ke = Z.key_expr(node.domain, SERVICE, TRIGGER)
        gid = bytes(range(16))
        pending = [node.session.get(ke, payload=b"\x00\x01\x00\x00\x00", timeout=20,
                                    attachment=Z.attachment(k, time.time_ns(), gid))
                   for k in range(1, 201)]
        answers = {}
        for h in pending:
            for r in h:
                assert r.ok is not None, r.err
                seq = Z.parse_attachment(r.ok.attachment.to_bytes())[0]
                answers[seq] = response(r.ok.payload.to_bytes())
    err = out["err"]
    assert sorted(answers) == list(range(1, 201))
    oks = [t for ok, t in answers.values() if ok]
    assert len(oks) >= 1 and all(t.startswith("tare offsets: ") for t in oks)
    assert all(t.startswith("busy") for ok, t in answers.values() if not ok)
    m = re.search(r"/fingertip/index/tare: (\d+) requests, (\d+) answered, (\d+) refused"
                  r"(?: \{.*\})?, (\d+) dropped", err)
    assert m and int(m[1]) == 200 and int(m[2]) + int(m[3]) == 200 and m[4] == "0", err[-1500:]
