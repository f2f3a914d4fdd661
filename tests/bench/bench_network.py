"""Publishing on the network: four virtual fingertips at 80 Hz, one 44.1 kHz audio stream and
the ONNX force model, published over DDS, Zenoh and LSL to a subscriber in another process.

The fingertips run in their own processes (`fingertip sim device`); the publisher is
`fingertip publish` (its CPU time, all threads, from /proc, is `publish_cpu_percent`, over
the DDS run); the subscriber is tests/bench/network_subscriber.py. Latency: from the host
time at which the frame's last byte was read (`arrival` in the raw message) to the moment
the subscriber has the message decoded. Lost: raw messages the publisher reports published
minus those the subscriber received (per fingertip; the publisher waits for the subscriber
before it starts streaming).
``BENCH_NETWORK_SECONDS`` shortens the 60 s runs.
"""
from __future__ import annotations

import json
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from tests.bench.bench_bridge import EXE, _force_model

SECONDS = float(os.environ.get("BENCH_NETWORK_SECONDS", "60"))
NAMES = [f"finger{i}" for i in range(4)]

DESCRIPTION = {
    "dds_latency_p99_ms": ("frame read on the host -> message decoded by a DDS subscriber "
                           "in another process, p99", ("<=", 2)),
    "dds_latency_p50_ms": ("the same, median", None),
    "dds_messages_lost": ("raw frames published but not received by the DDS subscriber",
                          ("<=", 0)),
    "zenoh_latency_p99_ms": ("the same over Zenoh (rmw_zenoh format, peer to peer)",
                             ("<=", 2)),
    "zenoh_messages_lost": ("raw frames missing at the Zenoh subscriber", ("<=", 0)),
    "lsl_latency_p99_ms": ("the same over Lab Streaming Layer", ("<=", 5)),
    "lsl_messages_lost": ("raw frames missing at the LSL inlet", None),
    "dds_received": ("raw frames received over DDS", None),
    "zenoh_received": ("raw frames received over Zenoh", None),
    "lsl_received": ("raw frames received over LSL", None),
    "publish_cpu_percent": ("CPU of the whole `fingertip publish` process (4 fingertips, "
                            "audio, force model, DDS), % of one core", ("<=", 8)),
    "network_seconds": ("length of each run", None),
    "publish_bridge_only_cpu_percent": ("CPU of the 4 bridges + force model alone (no audio) "
                                        "in one process, windows alternating with ...", None),
    "publish_added_cpu_percent": ("... the same with the feed publishing raw and wrench over "
                                  "DDS: what publishing adds, % of one core", None),
}


def _cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _one(transport: str, tmp: Path, model: Path) -> dict[str, float]:
    port = 17000 + os.getpid() % 2000
    endpoint = f"tcp/127.0.0.1:{port}"
    out = tmp / f"{transport}.json"
    sub_cmd = [sys.executable, "-m", "tests.bench.network_subscriber", transport, str(out),
               *NAMES]
    pub_extra: list[str] = []
    if transport == "zenoh":
        sub_cmd += ["--connect", endpoint]
        pub_extra = ["--zenoh-listen", endpoint]
    sub = subprocess.Popen(sub_cmd, stdout=subprocess.PIPE, text=True)
    sub.stdout.readline()
    ports = [a for k in range(4) for a in ("--port", str(tmp / f"ft{k}"))]
    pub = subprocess.Popen([EXE, "publish", *ports, "--name", ",".join(NAMES), "--transport",
                            transport, "--force-model", str(model), "--virtual-audio",
                            "--duration", str(SECONDS + 5), "--wait-subscribers", "1",
                            *pub_extra], stderr=subprocess.PIPE, text=True)
    pub.stderr.readline()  # "publishing ...": streaming has started
    time.sleep(3.0)  # warm-up
    c0, w0 = _cpu_s(pub.pid), time.monotonic()
    time.sleep(SECONDS)
    w1 = time.monotonic()
    cpu = 100 * (_cpu_s(pub.pid) - c0) / (w1 - w0)
    _, err = pub.communicate(timeout=60)
    time.sleep(0.5)
    sub.terminate()
    sub.wait(timeout=30)
    r = json.loads(out.read_text())
    # Latency over the measured window only (CLOCK_MONOTONIC is one clock for all
    # processes): the start-up of the subscriber's connections is not the steady state.
    lat = np.array([ms for t, ms in r["latency_ms"] if w0 <= t <= w1])
    published = {n: int(m) for n, m in re.findall(r"/fingertip/(\w+)/raw (\d+)", err)}
    if sorted(published) != sorted(NAMES):
        raise RuntimeError(f"publisher over {transport} failed: {err[-2000:]}")
    lost = sum(published[n] - r["received"][n] for n in NAMES)
    return {f"{transport}_latency_p99_ms": round(float(np.percentile(lat, 99)), 3),
            f"{transport}_latency_p50_ms": round(float(np.percentile(lat, 50)), 3),
            f"{transport}_messages_lost": lost,
            f"{transport}_received": sum(r["received"].values()),
            f"{transport}_publish_cpu_percent": round(cpu, 2)}


def _cpu_self() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _added_by_publishing(tmp: Path, model_path: Path, windows: int = 3, window_s: float = 5.0
                         ) -> tuple[float, float]:
    """CPU % of this process running the 4 bridges + force model, without and with the feed
    publishing over DDS (to a subscriber process), in alternating windows: what publishing
    adds, apart from the bridge it rides on."""
    from fingertip import Fingertip
    from fingertip.models.force.runtime import ForceModel
    from fingertip.network.dds import DdsTransport
    from fingertip.network.feed import Feed

    out = tmp / "added.json"
    sub = subprocess.Popen([sys.executable, "-m", "tests.bench.network_subscriber", "dds",
                            str(out), *NAMES], stdout=subprocess.PIPE, text=True)
    sub.stdout.readline()
    model = ForceModel(model_path)
    fts = [Fingertip(str(tmp / f"ft{k}")).open() for k in range(4)]
    feed = Feed(DdsTransport())
    on = [False]
    try:
        for ft, name in zip(fts, NAMES, strict=True):
            feed.add_fingertip(name, model)
            ft.add_callback(lambda f, _n=name: feed.frame(_n, f) if on[0] else model(f.counts))
            ft.start()
        time.sleep(2.0)
        shares: dict[bool, list[float]] = {False: [], True: []}
        for _ in range(windows):
            for state in (False, True):
                on[0] = state
                c0, w0 = _cpu_self(), time.monotonic()
                time.sleep(window_s)
                shares[state].append(100 * (_cpu_self() - c0) / (time.monotonic() - w0))
    finally:
        for ft in fts:
            ft.close()
        feed.transport.close()
        sub.terminate()
        sub.wait(timeout=30)
    return float(np.median(shares[False])), float(np.median(shares[True]))


def run() -> dict[str, float]:
    tmp = Path(tempfile.mkdtemp(prefix="bench-network-"))
    _force_model(tmp)
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
               ROS_DOMAIN_ID=str(100 + os.getpid() % 100))
    os.environ.update(env)  # the publisher and subscriber inherit it
    devices = []
    try:
        for k in range(4):
            p = subprocess.Popen([EXE, "sim", "device", "--link", str(tmp / f"ft{k}"),
                                  "--seed", str(k)], stdout=subprocess.PIPE, text=True)
            p.stdout.readline()
            devices.append(p)
        figures: dict[str, float] = {}
        for transport in ("dds", "zenoh", "lsl"):
            figures.update(_one(transport, tmp, tmp / "force.onnx"))
        bridge, publishing = _added_by_publishing(tmp, tmp / "force.onnx")
        figures["publish_bridge_only_cpu_percent"] = round(bridge, 2)
        figures["publish_added_cpu_percent"] = round(publishing - bridge, 2)
    finally:
        for p in devices:
            p.terminate()
            p.wait(timeout=10)
    figures["publish_cpu_percent"] = figures["dds_publish_cpu_percent"]
    figures["network_seconds"] = SECONDS
    return figures
