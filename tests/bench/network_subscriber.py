"""The subscriber process of bench_network: receives the raw frames of fingertips over DDS,
Zenoh or LSL and, at SIGTERM, writes latencies and the frames received per fingertip as
JSON (the device's sequence numbers also count its other messages, so losses are counted
against what the publisher says it published).
``python -m tests.bench.network_subscriber TRANSPORT OUT.json NAME... [--connect EP]``
"""
from __future__ import annotations

import argparse
import json
import signal
import threading
import time

from fingertip.record import schemas as S
from fingertip.record.timebase import TimeBase


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("transport", choices=("dds", "zenoh", "lsl"))
    ap.add_argument("out")
    ap.add_argument("names", nargs="+")
    ap.add_argument("--connect")
    args = ap.parse_args()
    tb = TimeBase.measure()
    lat: list[tuple[float, float]] = []  # (monotonic time received, latency ms)
    received: dict[str, int] = dict.fromkeys(args.names, 0)
    lock = threading.Lock()

    def on_message(name: str, kind: str, data: bytes) -> None:
        if kind != "raw":
            return
        t = time.monotonic()
        m = S.decode_raw(data)
        with lock:
            lat.append((t, (tb.to_ns(t) - m.arrival_ns) / 1e6))
            received[name] += 1

    if args.transport == "dds":
        from fingertip.network.dds import DdsNode, subscribe

        node = DdsNode()
        subscribe(node, args.names, on_message, kinds=("raw",))
    elif args.transport == "zenoh":
        from fingertip.network.zenoh import ZenohNode

        node = ZenohNode(connect=[args.connect] if args.connect else None)
        node.subscribe(args.names, on_message, kinds=("raw",))
    else:
        from fingertip.network.lsl import LslReceiver

        node = LslReceiver(args.names, on_message)
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    print("ready", flush=True)
    stop.wait()
    node.close()
    with lock:
        json.dump({"latency_ms": lat, "received": received}, open(args.out, "w"))


if __name__ == "__main__":
    main()
