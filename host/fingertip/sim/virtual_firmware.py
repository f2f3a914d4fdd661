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
        self._next_conversion_us = self.period_us
        self._conversions = 0
        self._next_stats_us = 1_000_000
        self._skip_next = False
        self.counters = dict.fromkeys(STATS_FIELDS[1:], 0)
        self._rx.reset()

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
        return (self.now_us - self.now_us % 4) % U32  # micros() counts in steps of 4 us

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
        self._next_conversion_us = start_us + self.period_us
        self._next_stats_us = start_us + 1_000_000
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
            self.rate_sps, self.decimation = cmd.rate_sps, cmd.decimation
            self._conversions = 0
            return self._send(ack)
        if isinstance(cmd, SetGain):
            if cmd.gain != self.gain:
                self.gain = cmd.gain
                self._skip_next = True  # that conversion was made with the old gain
            return self._send(ack)
        if isinstance(cmd, SetPower):
            self.powered = bool(cmd.on)
            if not self.powered:
                self.streaming = False
            else:
                self._next_conversion_us = self.now_us + 4 * self.period_us  # settling
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

    def advance(self, to_us: int) -> bytes:
        """Run device time forward to ``to_us``; return what the device sends meanwhile."""
        out = bytearray()
        while True:
            due = min(self._next_conversion_us if self.powered else to_us + 1,
                      self._next_stats_us if self.streaming else to_us + 1)
            if due > to_us:
                break
            self.now_us = due
            if self.streaming and due == self._next_stats_us:
                out += self._send(self._stats())
                self._next_stats_us += 1_000_000
            if self.powered and due == self._next_conversion_us:
                out += self._conversion()
                self._next_conversion_us += self.period_us
        self.now_us = max(self.now_us, to_us)
        return bytes(out)

    def _read_chips(self) -> tuple[list[int], int, int]:
        """One parallel read: raw 24-bit readings, timeout mask, saturation mask."""
        inputs = self.source(self.now_us)
        scale = {128: 1.0, 64: 0.5, 32: 0.25}[self.gain]
        raws, tmask, smask = [], 0, 0
        for i in range(self.channels):
            if self.dead_mask >> i & 1:
                tmask |= 1 << i
                self.counters["read_timeouts"] += 1
                raws.append(0)
                continue
            raw = max(INT24_MIN, min(INT24_MAX, int(round(inputs[i] * scale))))
            if raw in (INT24_MIN, INT24_MAX):
                smask |= 1 << i
                self.counters["saturations"] += 1
            raws.append(raw)
        return raws, tmask, smask

    def _tared(self, raws: list[int], tmask: int, smask: int) -> tuple[list[int], int]:
        values = []
        for i, raw in enumerate(raws):
            if tmask >> i & 1:
                values.append(0)
                continue
            v = raw - self.offsets[i]
            if not INT24_MIN <= v <= INT24_MAX:
                v = max(INT24_MIN, min(INT24_MAX, v))
                smask |= 1 << i
            values.append(v)
        return values, smask

    def _conversion(self) -> bytes:
        stamp = self._time()
        raws, tmask, smask = self._read_chips()
        if self._skip_next:
            self._skip_next = False
            return b""
        out = bytearray()
        if self._tare is not None:
            out += self._tare_step(raws, tmask)  # its ACK precedes frames with new offsets
        self._conversions += 1
        if self.streaming and self._conversions % self.decimation == 0:
            values, smask = self._tared(raws, tmask, smask)
            out += self._send(Sample(0, stamp, tuple(values), tmask, smask))
        return bytes(out)

    def _tare_step(self, raws: list[int], tmask: int) -> bytes:
        tare = self._tare
        assert tare is not None
        if tmask & tare.mask:
            self._tare = None
            return self._nack(tare.request_id, 0x05, ErrorCode.CHIP_TIMEOUT)
        for i in range(self.channels):
            if tare.mask >> i & 1:
                tare.sums[i] += raws[i]
        tare.taken += 1
        if tare.taken < tare.samples:
            return b""
        for i in range(self.channels):
            if tare.mask >> i & 1:
                # Round half away from zero, as the firmware's integer division does.
                s, n = tare.sums[i], tare.samples
                self.offsets[i] = (abs(s) + n // 2) // n * (1 if s >= 0 else -1)
        self._tare = None
        return self._send(Ack(0, tare.request_id, 0x05))
