"""A 10 s virtual fingertip run over Zenoh in rmw_zenoh's format: `record --from zenoh` in
another process receives every message (checked as for DDS), and a subscriber here sees
rmw_zenoh's attachments (sequence numbers, timestamps, GID) and liveliness tokens."""
from __future__ import annotations

import threading
import time
from collections import defaultdict

import pytest

from fingertip.network import zenoh as Z
from fingertip.record import schemas as S

from .test_dds_stream import run_and_compare

pytest.importorskip("zenoh")


def free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.slow
def test_every_message_of_a_10s_run_arrives_over_zenoh(tmp_path):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    attachments: dict[str, list] = defaultdict(list)
    tokens: list[str] = []

    done = threading.Event()

    def watch() -> None:
        # Another subscriber, in this process, connected to the publisher (peer mode).
        node = Z.ZenohNode(connect=[endpoint])
        try:
            node.subscribe(["index"], lambda n, k, d: None,
                           on_attachment=lambda n, k, a: attachments[k].append(a))
            t_end = time.monotonic() + 30
            while not attachments["raw"] and time.monotonic() < t_end:
                time.sleep(0.1)
            sel = f"@ros2_lv/{node.domain}/**"  # asked while the publisher is streaming
            tokens.extend(str(r.ok.key_expr) for r in node.session.liveliness().get(sel)
                          if r.ok is not None)
            done.wait(60)
        finally:
            node.close()

    t = threading.Thread(target=watch)
    try:
        sent = run_and_compare(tmp_path, "zenoh", sub_args=("--zenoh-connect", endpoint),
                               pub_args=("--zenoh-listen", endpoint), during=t.start,
                               subscribers=2)
    finally:
        done.set()
        t.join(timeout=20)
    # Attachments: 33 bytes (checked by the parser), one GID per publisher, sequence numbers
    # counting up by one from where this subscriber joined, timestamps near the stamps.
    raw = attachments["raw"]
    assert len(raw) >= 400  # the publisher waited for both subscribers: about 10 s of frames
    seqs = [a[0] for a in raw]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))
    assert len({a[2] for a in raw}) == 1 and len(raw[0][2]) == 16
    assert abs(raw[-1][1] - time.time_ns()) < 60 * S.NS
    # Liveliness: the node and a publisher token per topic, in rmw_zenoh's layout.
    pubs = [k for k in tokens if "/MP/" in k]
    assert any(k.endswith("/NN/%/%/fingertip") for k in tokens), tokens
    raw_token = next(k for k in pubs if "%fingertip%index%raw" in k)
    parts = raw_token.split("/")
    assert parts[0] == "@ros2_lv" and parts[5] == "MP" and parts[6:9] == ["%", "%",
                                                                          "fingertip"]
    assert parts[9:12] == ["%fingertip%index%raw", "fingertip_msgs::msg::dds_::StrainRaw_",
                           Z.type_hash(S.STRAIN_RAW)]
    assert parts[12] == "2::,5:,:,:,,"  # best effort, keep last 5
    # One publisher per topic of the fingertip: raw, wrench, audio, events, info. /diagnostics
    # is declared at its first 1 Hz status, so a busy machine may ask before or after it.
    own = [k for k in pubs if "%fingertip%index%" in k]
    assert len(own) == 5 and len(set(own)) == 5, pubs
    assert all("%diagnostics/diagnostic_msgs::msg::dds_::DiagnosticArray_/" in k
               for k in pubs if k not in own), pubs
    assert len(sent[S.topic("index", "raw")]) >= 780


def test_key_expressions_and_attachment_layout():
    assert Z.key_expr(0, "/fingertip/index/wrench", S.WRENCH_STAMPED) == (
        "0/fingertip/index/wrench/geometry_msgs::msg::dds_::WrenchStamped_/"
        "RIHS01_8dc3deaf06b2ab281f9f9a742a8961c328ca7cec16e3fd6586d3a5c83fa78f77")
    a = Z.attachment(5, -7, bytes(range(16)))
    assert len(a) == 33 and Z.parse_attachment(a) == (5, -7, bytes(range(16)))
    # zenoh-ext's own deserialiser reads it as (int64, int64, bytes): the layout rmw_zenoh's
    # zenoh::ext::Serializer writes.
    from zenoh import ZBytes
    from zenoh.ext import Int64, z_deserialize

    assert z_deserialize(tuple[Int64, Int64, bytes], ZBytes(a)) == (5, -7, bytes(range(16)))
    with pytest.raises(ValueError):
        Z.parse_attachment(a[:-1])
