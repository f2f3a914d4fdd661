"""The virtual device (fingertip.sim.VirtualFirmware: the firmware's C++ built for the host
and driven from Python on a simulated board) answers byte for byte as the same C++ does on
the AVR in simavr (16-bit int, avr-gcc, the real Arduino HAL and UART): boot message, every
command's answer, tare results, samples."""
from __future__ import annotations

import time

import pytest

from fingertip.protocol import (
    GetInfo, GetStats, Info, Ping, ResetCounters, Sample, SetGain, SetPower, SetRate,
    SetTareOffsets, Start, Stats, Stop, StreamDecoder, Tare, encode, seal,
)
from fingertip.sim import VirtualFirmware
from fingertip.transport import open_serial

INPUTS = [120_000, -250_000, 8_388_607, 42]


class Wire:
    """Collects the firmware's bytes and splits them into whole frames."""

    def __init__(self, port):
        self.port = port
        self.buf = b""

    def frames(self, n: int, timeout: float = 10.0) -> list[bytes]:
        out: list[bytes] = []
        deadline = time.monotonic() + timeout
        while len(out) < n and time.monotonic() < deadline:
            self.buf += self.port.read(4096, 0.02)
            while b"\x00" in self.buf and len(out) < n:
                i = self.buf.index(b"\x00")
                out.append(self.buf[:i + 1])
                self.buf = self.buf[i + 1:]
        assert len(out) == n, f"got {len(out)} of {n} frames"
        return out


@pytest.mark.parametrize("host_delay_s", [0.0, 0.03], ids=["prompt-host", "late-host"])
def test_twin_matches_the_firmware(make_sim, host_delay_s):
    sim = make_sim(4)
    for c, v in enumerate(INPUTS):
        sim.set(c, v)
    port = open_serial(sim.pty)
    sim.go()
    wire = Wire(port)
    fw_boot = b"".join(wire.frames(3))  # lone delimiter, INFO, LOG
    (boot_info, _) = StreamDecoder().feed(fw_boot)
    assert isinstance(boot_info, Info)
    twin = VirtualFirmware(4, source=lambda t: INPUTS, build_id=boot_info.build_id,
                           reset_cause=boot_info.reset_cause)
    assert twin.boot() == fw_boot

    script = [
        (Ping(1), 1), (GetInfo(2), 2), (SetRate(3, 80, 2), 1), (SetGain(4, 64), 1),
        (SetGain(5, 128), 1), (Tare(6, 0b10000, 4), 1),
        (seal(0x7E, 7), 1), (seal(0x05, 8), 1),
        (SetTareOffsets(9, 0b0101, (11, 0, -22) + (0,) * 13), 1), (GetInfo(10), 2),
        (Tare(11, 0b0011, 0), 1), (SetPower(12, 0), 1), (Start(13), 1), (Tare(14, 1, 4), 1),
        (SetPower(15, 1), 1), (SetPower(16, 1), 1), (ResetCounters(17), 1),
        (Tare(18, 0b1011, 8), 1), (GetInfo(19), 2), (Stop(20), 1),
    ]
    for cmd, n_answers in script:
        data = cmd if isinstance(cmd, bytes) else encode(cmd)
        time.sleep(host_delay_s)  # a busy host: the firmware runs on meanwhile
        # The command reaches both at the same simulated time, however late the host is
        # to write it: the simulation waits while it is written.
        sim.hold()
        t_twin = int(sim.time_us())
        assert twin.advance(t_twin) == b"", f"the twin spoke before {cmd}"
        port.write(data)
        sim.go()
        got = b"".join(wire.frames(n_answers, timeout=15))
        # The firmware takes the command ~1 ms later (its UART bytes) and a tare takes time
        # on both: run the twin on to just past the firmware's answer.
        t_twin = int(sim.time_us()) + 1_000
        want = twin.receive(data) + twin.advance(t_twin)
        assert got == want, f"{cmd}: firmware {got.hex()} twin {want.hex()}"

    # Counters: the same, apart from time and loop length; the reads counted (saturations)
    # depend on when the host asked, to within a read or two.
    sim.hold()
    t_twin = int(sim.time_us())
    port.write(encode(GetStats(21)))
    sim.go()
    fw_stats = StreamDecoder().feed(b"".join(wire.frames(2)))[0]
    twin.advance(t_twin)
    twin_stats = StreamDecoder().feed(twin.receive(encode(GetStats(21))))[0]
    assert isinstance(fw_stats, Stats) and isinstance(twin_stats, Stats)
    for k in ("frames_sent", "read_timeouts", "command_errors", "rx_overflows",
              "rx_crc_errors", "rx_framing_errors", "tx_overruns"):
        assert getattr(fw_stats, k) == getattr(twin_stats, k), k
    assert abs(fw_stats.saturations - twin_stats.saturations) <= 2

    # Streaming: the same values, masks and sequence numbers (the times differ in the
    # firmware's loop, by microseconds).
    port.write(encode(Start(22)))
    fw_msgs = StreamDecoder().feed(b"".join(wire.frames(12)))
    twin_msgs = StreamDecoder().feed(twin.receive(encode(Start(22)))
                                     + twin.advance(t_twin + 1_000_000))[:12]
    assert [type(m) for m in fw_msgs] == [type(m) for m in twin_msgs]
    for a, b in zip(fw_msgs, twin_msgs, strict=True):
        if isinstance(a, Sample):
            assert (a.seq, a.values, a.timeout_mask, a.saturation_mask) == \
                   (b.seq, b.values, b.timeout_mask, b.saturation_mask)
    port.close()
