"""A fingertip's commands: each sent with a request id, retried, and answered by ACK or NACK.

:class:`DeviceCommands` is the command half of :class:`~fingertip.device.Fingertip` (ping,
info, counters, start and stop, rate, gain, power, tare), over :meth:`~DeviceCommands._command`,
which keeps one pending entry per command until any of its attempts is answered. The reader
thread hands answers in through ``_on_answer`` and ``_attach``; a lost port fails what waits
(``_fail_pending``). It writes through the port link (``_write``, :mod:`.link`).
"""
from __future__ import annotations

import itertools
import logging
import numbers
import threading
import time
from collections import deque
from dataclasses import dataclass, field

from ..errors import EXIT_FAILED, BadArgumentError, BadArgumentTypeError
from ..protocol import (
    INT24_MAX, INT24_MIN, MAX_CHANNELS, VALID_GAINS, VALID_RATES, Ack, Command, ForeignInfo,
    GetInfo, GetStats, Info, Nack, Ping, ProtocolVersionError, ResetCounters, SetGain,
    SetPower, SetRate, SetTareOffsets, Start, Stats, Stop, Tare, encode, require_compatible,
)
from ..transport import TransportError
from .errors import (
    CommandFailed, CommandTimeout, FingertipError, NotConnected, check_int, check_tare_samples,
)
from .state import BridgeStats, Settings

log = logging.getLogger(__name__)


@dataclass
class PendingCommand:
    command: Command
    done: threading.Event = field(default_factory=threading.Event)
    replies: list = field(default_factory=list)
    result: Ack | Nack | None = None
    request_ids: set[int] = field(default_factory=set)
    """Every attempt's id: a late answer to an earlier attempt still proves the command ran."""


class DeviceCommands:
    """The commands of a :class:`~fingertip.device.Fingertip` (a mixin: the attributes below
    are the device's, set in its ``__init__``; ``channels`` and ``_not_open`` are its too)."""

    name: str
    port: str
    settings: Settings
    command_timeout: float
    retries: int
    _status: str
    _counters: BridgeStats
    _connected: threading.Event
    _info: Info | None
    _device_stats: Stats | None
    _pending: deque[PendingCommand]
    _pending_lock: threading.Lock
    _request_ids: itertools.cycle[int]

    def _handshake(self, timeout: float) -> Info:
        """GET_INFO until answered (a real Uno resets when the port opens and boots for ~2 s)."""
        deadline = time.monotonic() + timeout
        last: Exception | None = None
        while time.monotonic() < deadline:
            try:
                return self.get_info(timeout=min(0.5, max(0.05, deadline - time.monotonic())),
                                     retries=0)
            except ProtocolVersionError:
                raise
            except (CommandTimeout, NotConnected) as e:
                last = e
        raise CommandTimeout(f"{self.name}: no answer from a fingertip on {self.port} within "
                             f"{timeout:.1f} s (is the firmware flashed? right port?): {last}")

    # --- commands -------------------------------------------------------------------------

    def ping(self) -> float:
        """Round-trip time in seconds."""
        t0 = time.monotonic()
        self._command(Ping())
        return time.monotonic() - t0

    def get_info(self, timeout: float | None = None, retries: int | None = None) -> Info:
        replies = self._command(GetInfo(), timeout=timeout, retries=retries)
        info = next((r for r in replies if isinstance(r, (Info, ForeignInfo))), None)
        if info is None:
            raise FingertipError(f"{self.name}: ACK to GET_INFO came without INFO")
        self._info = require_compatible(info)
        return self._info

    def device_stats(self) -> Stats:
        """The device's own counters (GET_STATS)."""
        replies = self._command(GetStats())
        stats = next((r for r in replies if isinstance(r, Stats)), None)
        if stats is None:
            raise FingertipError(f"{self.name}: ACK to GET_STATS came without STATS")
        self._device_stats = stats
        return stats

    def start(self) -> None:
        self._command(Start())
        self.settings.streaming = True

    def stop(self) -> None:
        self._command(Stop())
        self.settings.streaming = False

    def set_rate(self, rate_sps: int, decimation: int = 1) -> None:
        """Tell the device its chips' rate (10 or 80 SPS) and keep every n-th conversion."""
        if rate_sps not in VALID_RATES:
            raise BadArgumentError(f"rate must be one of {', '.join(map(str, VALID_RATES))} SPS "
                             f"(the HX711's RATE pin), not {rate_sps!r}")
        decimation = check_int("decimation", decimation, 1, 255)
        self._command(SetRate(0, rate_sps, decimation))
        self.settings.rate_sps, self.settings.decimation = rate_sps, decimation

    def set_gain(self, gain: int) -> None:
        if gain not in VALID_GAINS:
            raise BadArgumentError(f"gain must be one of {', '.join(map(str, VALID_GAINS))}, "
                             f"not {gain!r}")
        self._command(SetGain(0, gain))
        self.settings.gain = gain

    def power(self, on: bool) -> None:
        self._command(SetPower(0, int(on)))
        if not on:
            self.settings.streaming = False

    def reset_counters(self) -> None:
        self._command(ResetCounters())

    def tare(self, channels: int | list[int] | None = None, samples: int = 16) -> tuple[int, ...]:
        """Average ``samples`` readings on the device and subtract them from then on.

        ``channels``: a list of channel numbers, a bit mask, or None for all. Returns the
        offsets now in use. ``samples=0`` clears the offsets of those channels.
        """
        samples = check_tare_samples(samples)
        n = self.channels
        if channels is None:
            mask = (1 << n) - 1
        elif isinstance(channels, int):
            mask = check_int("tare channel mask", channels, 1, 0xFFFF)  # the device judges
        else:
            if isinstance(channels, str | bytes) or not hasattr(channels, "__iter__"):
                raise BadArgumentTypeError(f"tare channels must be a list of channel numbers "
                                           f"(0..{n - 1}), a bit mask or None, not "
                                           f"{channels!r}")
            mask = 0
            for c in channels:
                if isinstance(c, bool) or not isinstance(c, numbers.Integral):
                    raise BadArgumentTypeError(f"tare channels are integers 0..{n - 1}, not "
                                               f"{c!r}")
                if not 0 <= c < n:
                    raise BadArgumentError(f"channel {c} does not exist (this device has {n})")
                mask |= 1 << c
            if not mask:
                raise BadArgumentError("tare needs at least one channel (an empty list was given)")
        s = self.settings
        # The device answers once it has averaged the samples; on top of that, the answer's
        # own allowance (command_timeout, 0.5 s by default) rather than a fixed one, so a
        # caller who allows for a slow link or a busy host gets it here too.
        wait = samples * s.decimation / s.rate_sps * 1.6 + self.command_timeout
        self._command(Tare(0, mask, samples), timeout=wait, retries=0)
        offsets = self.get_info().tare_offsets
        self.settings.offsets = offsets
        return offsets

    def set_tare_offsets(self, offsets: list[int] | tuple[int, ...]) -> None:
        """Put known offsets (one per channel) back on the device."""
        if len(offsets) != self.channels:
            raise BadArgumentError(f"need {self.channels} offsets, got {len(offsets)}")
        offsets = tuple(check_int("a tare offset", v, INT24_MIN, INT24_MAX) for v in offsets)
        padded = tuple(offsets) + (0,) * (MAX_CHANNELS - len(offsets))
        self._command(SetTareOffsets(0, (1 << len(offsets)) - 1, padded))
        self.settings.offsets = tuple(offsets)

    # --- sending a command, and its answers -----------------------------------------------

    def _command(self, cmd: Command, timeout: float | None = None,
                 retries: int | None = None) -> list:
        """Send ``cmd`` and wait for its ACK; return the messages that came before the ACK."""
        timeout = self.command_timeout if timeout is None else timeout
        retries = self.retries if retries is None else retries
        name = type(cmd).__name__
        if self._status == "closed":
            raise self._not_open()
        # One pending entry for all attempts: the answer to any of them completes the
        # command. A device or host slowed down (CPU load) answers attempt 1 after the
        # retry went out; throwing that answer away made every attempt wait for its own
        # answer alone, and three late answers in a row failed a command that had run.
        pending = PendingCommand(cmd)
        try:
            for attempt in range(retries + 1):
                if not self._connected.wait(timeout):
                    raise NotConnected(f"{self.name}: not connected ({self._status})")
                cmd.request_id = next(self._request_ids)
                with self._pending_lock:
                    pending.request_ids.add(cmd.request_id)
                    if attempt == 0:
                        self._pending.append(pending)
                try:
                    self._write(encode(cmd))
                except TransportError:
                    pass  # the reader notices the loss and reconnects; the retry goes out then
                if pending.done.wait(timeout):
                    res = pending.result
                    if res is None:  # the device went away after it had answered: exit 1
                        raise NotConnected(f"{self.name}: closed while waiting for {name}",
                                           exit_code=EXIT_FAILED)
                    if isinstance(res, Nack):
                        raise CommandFailed(name, res.error)
                    return pending.replies
                if attempt < retries:
                    self._counters.command_retries += 1
                    log.debug("%s: no answer to %s, retrying", self.name, name)
        finally:
            with self._pending_lock:
                if pending in self._pending:
                    self._pending.remove(pending)
        # An open device that stops answering fails at run time (exit status 1); the
        # handshake turns its own timeout into "no fingertip on this port" (2).
        raise CommandTimeout(f"{self.name}: no answer to {name} within {timeout:.2f} s "
                             f"({retries + 1} attempts)", exit_code=EXIT_FAILED)

    def _fail_pending(self) -> None:
        with self._pending_lock:
            for p in self._pending:
                p.done.set()
            self._pending.clear()

    def _on_answer(self, msg: Ack | Nack) -> None:
        with self._pending_lock:
            for p in self._pending:
                if msg.request_id in p.request_ids:
                    self._pending.remove(p)
                    p.result = msg
                    p.done.set()
                    return
        log.debug("%s: answer to an unknown request %d", self.name, msg.request_id)

    def _attach(self, msg, command_type: type) -> None:
        """INFO/STATS answers precede their ACK: give them to the oldest matching request."""
        with self._pending_lock:
            for p in self._pending:
                if isinstance(p.command, command_type):
                    p.replies.append(msg)
                    return
