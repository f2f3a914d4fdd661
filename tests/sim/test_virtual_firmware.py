"""The virtual device (the firmware's C++ on a simulated board) follows docs/protocol.md
sections 5 and 6."""
from __future__ import annotations

from fingertip.protocol import (
    Ack, ErrorCode, GetInfo, GetStats, Info, Log, Nack, Ping, ResetCounters, Sample, SetGain,
    SetPower, SetRate, Start, Stats, Stop, StreamDecoder, Tare, SetTareOffsets, encode,
)
from fingertip.sim import VirtualFirmware


def run(dev: VirtualFirmware, *cmds, until_us=None):
    dec = StreamDecoder("device")
    out = []
    for c in cmds:
        out += dec.feed(dev.receive(encode(c) if not isinstance(c, bytes) else c))
    if until_us is not None:
        out += dec.feed(dev.advance(until_us))
    assert dec.stats.errors_total == 0
    return out


def test_boot_sequence():
    dev = VirtualFirmware(4)
    raw = dev.boot()
    assert raw[0] == 0
    dec = StreamDecoder()
    info, log = dec.feed(raw)
    assert isinstance(info, Info) and info.is_boot and info.seq == 0
    assert (info.channels, info.rate_sps, info.decimation, info.gain) == (4, 80, 1, 128)
    assert not info.streaming and isinstance(log, Log) and log.seq == 1
    assert dec.stats.empty_frames == 1
    assert dev.advance(2_000_000) == b""  # not streaming at boot: nothing, not even STATS


def test_every_command_is_answered_in_order():
    dev = VirtualFirmware(4)
    dev.boot()
    out = run(dev, Ping(1), GetInfo(2), GetStats(3), SetRate(4, 10, 2), SetGain(5, 64),
              ResetCounters(6), Start(7), Stop(8), SetPower(9, 0), Start(10), SetPower(11, 1))
    kinds = [(type(m).__name__, getattr(m, "request_id", None)) for m in out]
    assert kinds == [("Ack", 1), ("Info", None), ("Ack", 2), ("Stats", None), ("Ack", 3),
                     ("Ack", 4), ("Ack", 5), ("Ack", 6), ("Ack", 7), ("Ack", 8), ("Ack", 9),
                     ("Nack", 10), ("Ack", 11)]
    assert out[-2].error == ErrorCode.POWERED_DOWN
    assert [m.seq for m in out] == list(range(2, 2 + len(out)))


def test_malformed_and_corrupt_commands():
    dev = VirtualFirmware(4)
    dev.boot()
    bad_rate = bytearray(encode(SetRate(3, 80, 1)))
    out = run(dev, Tare(1, 0x10, 4))  # channel 4 does not exist on a 4-channel device
    assert isinstance(out[0], Nack) and out[0].error == ErrorCode.BAD_ARGUMENT
    bad_rate[-2] ^= 0x01  # CRC corrupt: no answer, counted
    assert dev.receive(bytes(bad_rate)) == b""
    (stats, _) = run(dev, GetStats(4))
    assert stats.rx_crc_errors == 1 and stats.command_errors == 1


def test_streaming_rate_decimation_and_stats():
    dev = VirtualFirmware(4, source=lambda t: (t % 1000, -5, 1 << 24, -(1 << 24)))
    dev.boot()
    out = run(dev, Start(1), until_us=2_000_000)
    samples = [m for m in out if isinstance(m, Sample)]
    stats = [m for m in out if isinstance(m, Stats)]
    # The chips settle for 4 periods after power-up: the first sample is at 50 ms.
    assert len(samples) == 160 - 3 and len(stats) == 2
    assert samples[0].timestamp_us == 50_000
    assert samples[0].saturation_mask == 0b1100
    assert samples[0].values[2:] == ((1 << 23) - 1, -(1 << 23))
    run(dev, SetRate(2, 10, 5))
    out = run(dev, until_us=7_000_000)
    samples = [m for m in out if isinstance(m, Sample)]
    # 10 SPS after 4 periods (400 ms) of settling, every 5th conversion, for 5 s.
    assert len(samples) == 9
    assert samples[1].timestamp_us - samples[0].timestamp_us == 500_000


def test_tare_averages_then_subtracts():
    dev = VirtualFirmware(4, source=lambda t: (1000, -2001, 7, 0))
    dev.boot()
    out = run(dev, Start(1), Tare(2, 0b0011, 8), until_us=200_000)
    acks = [m for m in out if isinstance(m, Ack) and m.request_id == 2]
    assert len(acks) == 1
    after = [m for m in out if isinstance(m, Sample) and m.seq > acks[0].seq]
    assert after and all(s.values[:2] == (0, 0) and s.values[2] == 7 for s in after)
    info = [m for m in run(dev, GetInfo(3)) if isinstance(m, Info)][0]
    assert info.tare_offsets == (1000, -2001, 0, 0) and info.tare_mask == 0b0011
    out = run(dev, Tare(4, 0b0001, 0))
    assert isinstance(out[0], Ack)
    assert dev.offsets == [0, -2001, 0, 0]


def test_dead_chip_is_flagged_and_fails_tare():
    dev = VirtualFirmware(4, source=lambda t: (1, 2, 3, 4))
    dev.boot()
    dev.dead_mask = 0b0100
    out = run(dev, Start(1), Tare(2, 0b0100, 4), until_us=100_000)
    nacks = [m for m in out if isinstance(m, Nack)]
    assert nacks and nacks[0].error == ErrorCode.CHIP_TIMEOUT
    samples = [m for m in out if isinstance(m, Sample)]
    assert all(s.timeout_mask == 0b0100 and s.values == (1, 2, 0, 4) for s in samples)


def test_busy_during_tare_and_gain_change_discards_one_reading():
    dev = VirtualFirmware(4, source=lambda t: (1000,) * 4)
    dev.boot()
    out = run(dev, Start(1), Tare(2, 1, 100), SetRate(3, 80, 1), Tare(4, 1, 1))
    assert [m.error for m in out if isinstance(m, Nack)] == [ErrorCode.BUSY, ErrorCode.BUSY]
    dev2 = VirtualFirmware(4, source=lambda t: (1000,) * 4)
    dev2.boot()
    out = run(dev2, Start(1), SetGain(2, 64), until_us=100_000)
    samples = [m for m in out if isinstance(m, Sample)]
    # Reads at 50, 62.5, 75, 87.5 and 100 ms; the first still had gain 128: discarded.
    assert len(samples) == 4 and samples[0].values[0] == 500
    assert samples[0].timestamp_us == 62_500


def test_set_tare_offsets_restores_a_calibration():
    dev = VirtualFirmware(4, source=lambda t: (100, 200, 300, 400))
    dev.boot()
    offs = (10, -20, 0, 0) + (0,) * 12
    out = run(dev, SetTareOffsets(1, 0b0011, offs), Start(2), until_us=60_000)
    assert isinstance(out[0], Ack)
    sample = [m for m in out if isinstance(m, Sample)][0]
    assert sample.values == (90, 220, 300, 400)
    out = run(dev, SetTareOffsets(3, 0b10000, (0,) * 16))
    assert isinstance(out[0], Nack) and out[0].error == ErrorCode.BAD_ARGUMENT


def test_timeouts_follow_the_firmware():
    """A chip that dies delays one read to the deadline; a revived chip's first reading is
    discarded; with every chip dead, all-timeout frames come every 1.5 periods."""
    dev = VirtualFirmware(4, source=lambda t: (1, 2, 3, 4))
    dev.boot()
    run(dev, Start(1), until_us=100_000)
    dev.dead_mask = 0b0010
    out = [m for m in run(dev, until_us=200_000) if isinstance(m, Sample)]
    # The deadline is 1.5 periods later; micros() steps by 4 us: the first reading at or
    # after it is 18 752 us later.
    assert out[0].timestamp_us == 100_000 + 18_752
    assert all(m.timeout_mask == 0b0010 for m in out)
    assert [m.timestamp_us % 12_500 for m in out[1:]] == [0] * len(out[1:])
    dev.dead_mask = 0
    out = [m for m in run(dev, until_us=250_000) if isinstance(m, Sample)]
    assert out[0].timeout_mask == 0b0010 and out[1].timeout_mask == 0  # revived: discarded
    dev.dead_mask = 0b1111
    out = [m for m in run(dev, until_us=400_000) if isinstance(m, Sample)]
    steps = {b.timestamp_us - a.timestamp_us for a, b in zip(out[1:], out[2:], strict=False)}
    assert steps <= {18_748, 18_752} and all(m.timeout_mask == 0b1111 for m in out)
