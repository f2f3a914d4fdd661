"""RDT codec, the RDT client against the reference simulator over UDP loopback, and the
reference CSV reader."""
from __future__ import annotations

import socket
import time

import numpy as np
import pytest

from fingertip.reference import (
    RdtClient,
    ReferenceError,
    ReferenceFormatError,
    ReferenceSamples,
    decode_record,
    encode_request,
    load_reference_csv,
)
from fingertip.reference.rdt import (
    CMD_START,
    HEADER,
    RECORD,
    RdtRecord,
    decode_request,
    smooth_arrivals,
)
from fingertip.sim.device.rdt_server import RdtServer


def test_request_layout():
    data = encode_request(CMD_START, 0)
    assert data == bytes([0x12, 0x34, 0x00, 0x02, 0, 0, 0, 0])
    assert decode_request(encode_request(0x42, 7)) == (0x42, 7)
    with pytest.raises(ValueError):
        decode_request(b"\x00" * 8)  # wrong header
    with pytest.raises(ValueError):
        decode_request(b"\x12\x34")
    assert HEADER == 0x1234


def test_record_layout_round_trip():
    r = RdtRecord(0xFFFFFFFF, 5, 0, (-1_500_000, 2, 3, -4, 5, 2 ** 31 - 1))
    data = r.encode()
    assert len(data) == RECORD.size == 36
    assert data[:4] == b"\xff\xff\xff\xff" and data[12:16] == (-1_500_000).to_bytes(4, "big",
                                                                                  signed=True)
    assert decode_record(data) == r
    with pytest.raises(ValueError):
        decode_record(data[:-1])


def test_smooth_arrivals_removes_jitter():
    rng = np.random.default_rng(0)
    seq = np.arange(5000.0)
    true = 12.0 + seq / 1000.0
    arrival = true + 0.004 + rng.exponential(0.0008, len(seq))
    est = smooth_arrivals(seq, arrival)
    assert np.max(np.abs(est - (true + 0.004))) < 2e-4


@pytest.mark.realtime
def test_client_and_simulator_over_loopback():
    t0 = time.monotonic()

    def force_at(t: float) -> np.ndarray:
        return np.array([1.5, -0.25 * (t - t0), 0.0])

    with RdtServer(force_at, delay_s=0.0, noise_n=0.0, loss=0.1, seed=3,
                   counts_per_force=1e6) as srv:
        cli = RdtClient("127.0.0.1", srv.port)
        cli.start()
        time.sleep(0.6)
        ref = cli.stop()
    assert 350 < len(ref) < 800
    assert ref.counters["lost"] > 10  # 10 % lost on the way, counted from the sequence gaps
    assert ref.counters["lost"] + ref.counters["packets"] >= srv.sent
    assert np.allclose(ref.force[:, 0], 1.5)
    assert np.all(np.diff(ref.times_s) > 0)
    # Smoothed times follow the send times: the ramp read back at those times fits.
    assert np.allclose(ref.force[:, 1], -0.25 * (ref.times_s - t0), atol=0.01)


def test_no_packets_is_one_clear_error():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))  # a port where nobody answers
    port = s.getsockname()[1]
    try:
        cli = RdtClient("127.0.0.1", port, first_packet_timeout=0.3)
        with pytest.raises(ReferenceError, match="no RDT packets"):
            cli.start()
    finally:
        s.close()


def write(path, text):
    path.write_text(text, encoding="utf-8")
    return path


def test_csv_reference(tmp_path):
    p = write(tmp_path / "r.csv", "Time_s,Fx_N,Fy_N,extra\n0.0,1,2,x\n0.001,1.5,2.5,y\n")
    r = load_reference_csv(p)
    assert r.times_s.tolist() == [0.0, 0.001] and r.force[1].tolist() == [1.5, 2.5, 0.0]


@pytest.mark.parametrize("text,match", [
    ("t,fx\n0,1\n", "no column for fy"),
    ("a,b\n0,1\n", "no column for time, fx, fy"),
    ("t,fx,fy\n0,1,1\n0.2,1,1\n0.1,1,1\n", "times must increase"),
    ("t,fx,fy\n0,1,1\n0,1,1\n", "times must increase"),
    ("t,fx,fy\n0,1,x\n", "not a number"),
    ("t,fx,fy\n0,1,nan\n", "NaN"),
    ("", "empty"),
])
def test_csv_reference_bad(tmp_path, text, match):
    with pytest.raises(ReferenceFormatError, match=match):
        load_reference_csv(write(tmp_path / "r.csv", text))


def test_reference_that_never_moves():
    t = np.arange(1000) / 1000
    still = ReferenceSamples(t, np.random.default_rng(0).normal(0, 0.01, (1000, 3)))
    with pytest.raises(ReferenceError, match="never moves"):
        still.require_usable()
    with pytest.raises(ReferenceError, match="only 3 samples"):
        ReferenceSamples(t[:3], np.zeros((3, 3))).require_usable()
