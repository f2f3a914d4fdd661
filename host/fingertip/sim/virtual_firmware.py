"""A pure-Python fingertip device: the firmware's behaviour (docs/protocol.md, sections 5-6).

No I/O and no clock of its own: the caller advances device time and moves the bytes, so the
same object runs behind a pty in real time (:mod:`fingertip.sim.pty_device`), inside a test
as fast as Python goes, or in lock-step with a physics model. Its output for the same inputs
is compared with the real firmware's in simavr by the firmware-in-the-loop tests.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from ..protocol import (
    INT24_MAX,
    INT24_MIN,
    MAX_CHANNELS,
    MAX_TARE_SAMPLES,
    Ack,
    ErrorCode,
    GetInfo,
    GetStats,
    Info,
    InfoReason,
    Log,
    MsgType,
    LogLevel,
    Nack,
    Ping,
    RejectedCommand,
    ResetCounters,
    Sample,
    SetGain,
    SetPower,
    SetRate,
    SetTareOffsets,
    Start,
    Stats,
    Stop,
    StreamDecoder,
    Tare,
    encode,
)
from ..protocol.messages import STATS_FIELDS

FIRMWARE_VERSION = (0, 1, 0)
U32 = 1 << 32
SETTLE_PERIODS = 4  # conversions after power-up or a rate change before data is good
GAIN_SCALE = {128: 1.0, 64: 0.5, 32: 0.25}  # input counts are given at gain 128

CountsSource = Callable[[int], Sequence[float]]
"""Device time in microseconds -> each chip's input in counts (before clipping)."""


@dataclass
class _Tare:
    request_id: int
    mask: int
    samples: int
    sums: list[int] = field(default_factory=list)
    taken: int = 0


class VirtualFirmware:
    """Behaves as the Uno firmware does, frame for frame, given the chips' inputs."""

    def __init__(self, channels: int = 4, source: CountsSource | None = None,
                 build_id: int = 0, reset_cause: int = 1) -> None:
        if not 1 <= channels <= MAX_CHANNELS:
            raise ValueError(f"channels must be 1..{MAX_CHANNELS}")
        self.channels = channels
        self.source: CountsSource = source or (lambda t: (0,) * channels)
        self.build_id = build_id
        self.reset_cause = reset_cause
        self.dead_mask = 0
        """Chips that never become ready (missing or broken)."""
        self._rx = StreamDecoder("host")
        self.reset()

    # --- state ----------------------------------------------------------------------------

    def reset(self) -> None:
        """Power-on state, as after a reset of the Uno (call :meth:`boot` for its output)."""
        self.now_us = 0
        self.rate_sps = 80
        self.decimation = 1
        self.gain = 128
        self.streaming = False
        self.powered = True
        self.offsets = [0] * self.channels
        self._seq = 0
        self._tare: _Tare | None = None
        self._next_stats_us = 1_000_000
        self.counters = dict.fromkeys(STATS_FIELDS[1:], 0)
        self._rx.reset()
        # Chip bookkeeping, as firmware/lib/fingertip_core/device.cpp keeps it.
        self._next_tick_us = 0       # the chips' next conversion-ready time
        self._deadline_us = 0        # read anyway (with timeout bits) at this time
        self._settle_until_us = 0
        self._settling = False
        self._chip_gain = 128
        self._live = (1 << self.channels) - 1  # channels the next read waits for
        self._stale = 0              # channels back from a timeout: first reading discarded
        self._dec_count = 0

    @property
    def period_us(self) -> int:
        return 1_000_000 // self.rate_sps

    @property
    def flags(self) -> int:
        return int(self.streaming) | int(not self.powered) << 1 | int(self._tare is not None) << 2

    def _send(self, msg) -> bytes:
        msg.seq = self._seq
        self._seq = (self._seq + 1) & 0xFFFF
        self.counters["frames_sent"] += 1
        return encode(msg)

    def _time(self) -> int:
        return _micros(self.now_us)

    def _info(self, reason: int) -> Info:
        mask = sum(1 << i for i, v in enumerate(self.offsets) if v)
        return Info(0, 1, 0, FIRMWARE_VERSION, self.build_id, reason, self.reset_cause,
                    self.channels, self.rate_sps, self.decimation, self.gain, self.flags,
                    mask, tuple(self.offsets))

    def _stats(self) -> Stats:
        return Stats(0, self._time(), **{k: v & 0xFFFFFFFF for k, v in self.counters.items()})

    # --- output ---------------------------------------------------------------------------

    def boot(self, start_us: int = 0) -> bytes:
        """Reset, and return the bytes a freshly reset device sends. ``start_us``: the device
        clock at boot (a real one starts at 0; later values test the 32-bit wraparound)."""
        self.reset()
        self.now_us = start_us
        self._next_stats_us = start_us + 1_000_000
        self.powered = False
        self._power(True)
        text = (f"fingertip fw {'.'.join(map(str, FIRMWARE_VERSION))}, "
                f"{self.channels} channels")
        return (b"\x00" + self._send(self._info(InfoReason.BOOT))
                + self._send(Log(0, LogLevel.INFO, text)))

    def receive(self, data: bytes) -> bytes:
        """Take host bytes at the current device time; return the immediate answers."""
        out = bytearray()
        for item in self._rx.feed(data):
            out += self._handle(item)
        st = self._rx.stats
        self.counters["rx_crc_errors"] = st.crc
        self.counters["rx_framing_errors"] = st.cobs + st.too_short
        self.counters["rx_overflows"] = st.too_long
        return bytes(out)

    def _nack(self, request_id: int, command: int, error: ErrorCode) -> bytes:
        self.counters["command_errors"] += 1
        return self._send(Nack(0, request_id, command, error))

    def _handle(self, cmd) -> bytes:
        if isinstance(cmd, RejectedCommand):
            return self._nack(cmd.request_id, cmd.command, cmd.error)
        rid, t = cmd.request_id, int(cmd.TYPE)
        ack = Ack(0, rid, t)
        if isinstance(cmd, Ping):
            return self._send(ack)
        if isinstance(cmd, GetInfo):
            return self._send(self._info(InfoReason.REQUEST)) + self._send(ack)
        if isinstance(cmd, GetStats):
            return self._send(self._stats()) + self._send(ack)
        if isinstance(cmd, ResetCounters):
            for k in self.counters:
                self.counters[k] = 0
            self._rx.stats.reset()
            return self._send(ack)
        if isinstance(cmd, Stop):
            self.streaming = False
            return self._send(ack)
        if isinstance(cmd, Start):
            if not self.powered:
                return self._nack(rid, t, ErrorCode.POWERED_DOWN)
            if not self.streaming:
                self.streaming = True
                self._next_stats_us = self.now_us + 1_000_000
            return self._send(ack)
        if isinstance(cmd, Tare):
            return self._start_tare(cmd)
        if self._tare is not None:
            return self._nack(rid, t, ErrorCode.BUSY)
        if isinstance(cmd, SetTareOffsets):
            if not cmd.channel_mask or cmd.channel_mask >> self.channels:
                return self._nack(rid, t, ErrorCode.BAD_ARGUMENT)
            for i in range(self.channels):
                if cmd.channel_mask >> i & 1:
                    self.offsets[i] = cmd.offsets[i]
            return self._send(ack)
        if isinstance(cmd, SetRate):
            if cmd.rate_sps != self.rate_sps:
                self.rate_sps = cmd.rate_sps
                if self.powered:
                    # The chips restart their conversions at the new rate, and settle.
                    self._next_tick_us = self.now_us + SETTLE_PERIODS * self.period_us
                    self._expect_settling(self.now_us)
            self.decimation = cmd.decimation
            self._dec_count = 0
            return self._send(ack)
        if isinstance(cmd, SetGain):
            # The next reading still has the old gain: _read discards it (chip gain differs).
            self.gain = cmd.gain
            return self._send(ack)
        if isinstance(cmd, SetPower):
            self._power(bool(cmd.on))
            return self._send(ack)
        return self._nack(rid, t, ErrorCode.UNKNOWN_COMMAND)

    def _start_tare(self, cmd: Tare) -> bytes:
        rid, t = cmd.request_id, int(cmd.TYPE)
        if self._tare is not None:
            return self._nack(rid, t, ErrorCode.BUSY)
        if cmd.channel_mask >> self.channels or not cmd.channel_mask \
                or cmd.samples > MAX_TARE_SAMPLES:
            return self._nack(rid, t, ErrorCode.BAD_ARGUMENT)
        if not self.powered:
            return self._nack(rid, t, ErrorCode.POWERED_DOWN)
        if cmd.samples == 0:
            for i in range(self.channels):
                if cmd.channel_mask >> i & 1:
                    self.offsets[i] = 0
            return self._send(Ack(0, rid, t))
        self._tare = _Tare(rid, cmd.channel_mask, cmd.samples, [0] * self.channels)
        return b""

    # --- chips ----------------------------------------------------------------------------

    def _power(self, on: bool) -> None:
        if on == self.powered:
            return
        self.powered = on
        if not on:
            self.streaming = False
            return
        # The chips restart at gain 128 and settle for 4 periods before their first
        # conversion; the first read sets our gain (and is discarded if that differs).
        self._chip_gain = 128
        self._live = (1 << self.channels) - 1
        self._stale = 0
        self._dec_count = 0
        self._next_tick_us = self.now_us + SETTLE_PERIODS * self.period_us
        self._expect_settling(self.now_us)

    def _expect_settling(self, now: int) -> None:
        period = self.period_us
        self._settling = True
        self._settle_until_us = now + SETTLE_PERIODS * period
        self._deadline_us = self._settle_until_us + period + period // 2

    @property
    def next_due_us(self) -> int | None:
        """Device time of the next thing the device does on its own (a conversion, a chip
        deadline, a statistics frame), or None when nothing is due: a host serving the
        device can sleep until then instead of polling."""
        times = []
        if self.powered:
            times += [self._next_tick_us, self._deadline_us]
        if self.streaming:
            times.append(self._next_stats_us)
        return min(times) if times else None

    def advance(self, to_us: int) -> bytes:
        """Run device time forward to ``to_us``; return what the device sends meanwhile."""
        out = bytearray()
        never = to_us + 1
        while True:
            tick = self._next_tick_us if self.powered else never
            deadline = self._deadline_us if self.powered else never
            stats = self._next_stats_us if self.streaming else never
            due = min(tick, deadline, stats)
            if due > to_us:
                break
            self.now_us = due
            if due == stats:
                out += self._send(self._stats())
                self._next_stats_us += 1_000_000
                continue
            if due == tick:
                self._next_tick_us += self.period_us
                alive = self._all_mask & ~self.dead_mask
                live = self._live
                go = (alive & live) == live if live else alive != 0
                if not go:
                    continue  # wait for the missing chips until the deadline
            out += self._read(self._all_mask & ~self.dead_mask)
        self.now_us = max(self.now_us, to_us)
        return bytes(out)

    @property
    def _all_mask(self) -> int:
        return (1 << self.channels) - 1

    def _read(self, ready: int) -> bytes:
        """One parallel read at ``now_us`` of the chips in ``ready`` (device.cpp's
        processReading)."""
        stamp = self.now_us
        period = self.period_us
        timeouts = self._all_mask & ~ready
        valid = ready & ~self._stale
        self._stale = timeouts
        self._live = valid
        inputs = self.source(stamp)
        scale = GAIN_SCALE[self._chip_gain]
        raws = [0] * self.channels
        for i in range(self.channels):
            if timeouts >> i & 1:
                self.counters["read_timeouts"] += 1
                continue
            raws[i] = max(INT24_MIN, min(INT24_MAX, int(round(inputs[i] * scale))))
            if valid >> i & 1 and raws[i] in (INT24_MIN, INT24_MAX):
                self.counters["saturations"] += 1

        discard = False
        if ready and self._chip_gain != self.gain:
            discard = True
            self._chip_gain = self.gain
            self._settling = True
            self._settle_until_us = stamp + SETTLE_PERIODS * period
        self._deadline_us = stamp + period + period // 2
        if self._settling:
            if stamp >= self._settle_until_us:
                self._settling = False
            else:
                self._deadline_us = max(self._deadline_us,
                                        self._settle_until_us + period + period // 2)

        out = bytearray()
        tare = self._tare
        tare_failed = tare is not None and bool(tare.mask & ~valid)
        tare_done = False
        if not discard:
            self._dec_count += 1
            if self._dec_count >= self.decimation:
                self._dec_count = 0
                values, smask = [0] * self.channels, 0
                for i in range(self.channels):
                    if not valid >> i & 1:
                        continue
                    v = raws[i] - self.offsets[i]
                    if raws[i] in (INT24_MIN, INT24_MAX) or not INT24_MIN <= v <= INT24_MAX:
                        smask |= 1 << i
                    values[i] = max(INT24_MIN, min(INT24_MAX, v))
                if tare is not None and not tare_failed:
                    for i in range(self.channels):
                        if tare.mask >> i & 1:
                            tare.sums[i] += raws[i]
                    tare.taken += 1
                    tare_done = tare.taken >= tare.samples
                # The SAMPLE of the last tare reading still has the old offsets; the ACK
                # follows it, and every SAMPLE after the ACK has the new ones.
                if self.streaming:
                    out += self._send(Sample(0, _micros(stamp), tuple(values),
                                             self._all_mask & ~valid, smask))
        if tare_failed:
            out += self._finish_tare(False)
        elif tare_done:
            out += self._finish_tare(True)
        return bytes(out)

    def _finish_tare(self, ok: bool) -> bytes:
        tare = self._tare
        assert tare is not None
        self._tare = None
        if not ok:  # the old offsets are kept
            return self._nack(tare.request_id, int(MsgType.TARE), ErrorCode.CHIP_TIMEOUT)
        for i in range(self.channels):
            if tare.mask >> i & 1:
                # Round half away from zero, as the firmware's integer division does.
                s, n = tare.sums[i], tare.samples
                self.offsets[i] = (abs(s) + n // 2) // n * (1 if s >= 0 else -1)
        return self._send(Ack(0, tare.request_id, int(MsgType.TARE)))


def _micros(t_us: int) -> int:
    """What the Uno's micros() reads at ``t_us``: steps of 4 us, wrapping at 2^32."""
    return (t_us - t_us % 4) % U32
