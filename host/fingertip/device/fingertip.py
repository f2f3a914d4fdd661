"""``Fingertip``: one device, its commands, its frame stream, its counters, its clock.

A background thread reads the port (its own, or one :class:`SharedReader` for several
devices), decodes frames, maps device time to host time and hands frames to a bounded queue
(none with ``queue_size=0``, for consumers that take frames by callback) and to callbacks.
Commands wait for their ACK or NACK. When the port vanishes (cable pulled, pty closed,
simulator restarted) or the device resets, the thread reconnects by itself, re-applies
rate, gain and tare offsets and resumes streaming, and counts it; user loops only ever see
it through :attr:`Fingertip.status`.
"""
from __future__ import annotations

import itertools
import logging
import numbers
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

from ..protocol import (
    INT24_MAX, INT24_MIN,
    MAX_CHANNELS, MAX_TARE_SAMPLES, VALID_GAINS, VALID_RATES, Ack, Command, ErrorCode,
    ForeignInfo, GetInfo, GetStats, Info, Log, Nack,
    Ping, ProtocolVersionError, ResetCounters, Sample, SetGain, SetPower, SetRate,
    SetTareOffsets, Start, Stats, Stop, StreamDecoder, Tare, encode, require_compatible,
)
from ..transport import ByteStream, TransportError, find_port, open_serial
from .frames import FrameSource
from .reader import SharedReader, stream_fileno
from .timesync import ClockSync

log = logging.getLogger(__name__)

DEVICE_RATES = (1_000_000, 115_200)
"""UART rates a fingertip's firmware runs at, the current default first (exact at 16 MHz;
firmware built before 1 Mbaud became the default runs at 115200): with ``baudrate=None``,
:meth:`Fingertip.open` tries each in turn until the device answers."""

StreamFactory = Callable[[str], ByteStream]


class FingertipError(RuntimeError):
    """Base class of the errors a :class:`Fingertip` raises from its commands."""


class CommandFailed(FingertipError):
    """The device answered NACK. ``code`` is the :class:`ErrorCode`."""

    def __init__(self, command: str, code: int) -> None:
        try:
            name = ErrorCode(code).name
        except ValueError:
            name = f"error {code}"
        super().__init__(f"{command} refused by the device: {name}")
        self.code = code


class CommandTimeout(FingertipError, TimeoutError):
    """No answer from the device in time (after the retries)."""


class NotConnected(FingertipError):
    """The device is not connected (closed, or reconnecting for longer than the timeout)."""


def check_int(name: str, value: object, lo: int, hi: int) -> int:
    """``value`` as an int if it is an integer in lo..hi, else a ValueError (TypeError for
    a non-integer) that names the allowed range."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an integer in {lo}..{hi}, not {value!r}")
    v = int(value)  # type: ignore[arg-type]
    if not lo <= v <= hi:
        raise ValueError(f"{name} must be in {lo}..{hi}, not {v}")
    return v


def _identity(info: Info) -> tuple:
    """What must not change across a reconnect: protocol, firmware, build, channels."""
    return (info.protocol_major, tuple(info.firmware_version), info.build_id, info.channels)


def _describe(ident: tuple) -> str:
    major, fw, build, channels = ident
    return f"{'.'.join(map(str, fw))} build {build:08x}, {channels} channels, protocol v{major}"


def check_tare_samples(samples: object) -> int:
    """Readings a tare averages: 1..256, or 0 to clear the offsets (the firmware's limit)."""
    return check_int("tare samples", samples, 0, MAX_TARE_SAMPLES)


@dataclass(frozen=True, slots=True)
class Frame:
    """One sample frame, as user code sees it."""

    seq: int
    device_time_us: int
    """Device microseconds, unwrapped (no 32-bit wraparound)."""
    host_time: float
    """Device time mapped to this host's ``time.monotonic()`` seconds (drift corrected): when
    the chips signalled this reading ready, as this host's clock would have read then."""
    arrival_time: float
    """``time.monotonic()`` when the frame's last byte was read."""
    counts: tuple[int, ...]
    """Raw HX711 counts per channel, tare offsets already subtracted by the device."""
    timeout_mask: int = 0
    saturation_mask: int = 0

    @property
    def ok(self) -> bool:
        """No channel timed out or saturated."""
        return not (self.timeout_mask | self.saturation_mask)

    def valid(self, channel: int) -> bool:
        return not ((self.timeout_mask | self.saturation_mask) >> channel & 1)


@dataclass(slots=True)
class BridgeStats:
    """What the host saw (the device's own counters: :meth:`Fingertip.device_stats`)."""

    frames_ok: int = 0
    bytes_in: int = 0
    crc_errors: int = 0
    cobs_errors: int = 0
    length_errors: int = 0
    """Frames too short or too long (the device's ``rx_framing_errors`` is another count: COBS
    errors and short frames among the commands it received)."""
    unknown_type: int = 0
    bad_payload: int = 0
    seq_gaps: int = 0
    frames_lost: int = 0
    overruns: int = 0
    """Frames dropped because user code did not read the queue fast enough (never counted
    with ``queue_size=0``: there is no queue, callbacks get every frame)."""
    reconnects: int = 0
    device_resets: int = 0
    callback_errors: int = 0
    command_retries: int = 0
    log_lines: int = 0
    foreign_devices: int = 0
    """Reconnects refused because another kind of device answered on the port (another
    firmware, build or channel count): its frames are never handed out."""


@dataclass
class _Pending:
    command: Command
    done: threading.Event = field(default_factory=threading.Event)
    replies: list = field(default_factory=list)
    result: Ack | Nack | None = None
    request_ids: set[int] = field(default_factory=set)
    """Every attempt's id: a late answer to an earlier attempt still proves the command ran."""


@dataclass
class Settings:
    """What the host wants the device to be; re-applied after a reconnect or reset."""

    rate_sps: int = 80
    decimation: int = 1
    gain: int = 128
    offsets: tuple[int, ...] = ()
    streaming: bool = False


class Fingertip(FrameSource):
    """One fingertip device.

    Open it by ``port`` (``/dev/ttyACM0``, a pty path, a by-id link) or by the USB
    ``serial_number`` of its Arduino. ``open_stream`` replaces pyserial (tests, files).
    ``queue_size=0``: no frame queue, frames reach callbacks only (:meth:`read`,
    :meth:`frames` and :meth:`drain` then raise). ``reader``: a :class:`SharedReader`
    that reads this port on one thread with other devices' ports.

    >>> with Fingertip("/dev/ttyACM0") as ft:           # doctest: +SKIP
    ...     ft.tare(samples=16)
    ...     ft.start()
    ...     for frame in ft.frames(timeout=1.0):
    ...         print(frame.host_time, frame.counts)
    """

    def __init__(self, port: str | None = None, *, serial_number: str | None = None,
                 baudrate: int | None = None, open_stream: StreamFactory | None = None,
                 queue_size: int = 4096, reconnect: bool = True,
                 command_timeout: float = 0.5, retries: int = 2, open_timeout: float = 4.0,
                 name: str | None = None, reader: SharedReader | None = None) -> None:
        if (port is None) == (serial_number is None):
            raise ValueError("give exactly one of port or serial_number")
        check_int("queue_size", queue_size, 0, 1 << 24)
        check_int("retries", retries, 0, 100)
        if baudrate is not None:
            check_int("baudrate", baudrate, 1, 10_000_000)
        for what, v in (("command_timeout", command_timeout), ("open_timeout", open_timeout)):
            if not (isinstance(v, int | float) and 0 < v < float("inf")):
                raise ValueError(f"{what} must be a positive number of seconds, not {v!r}")
        self._port_arg = port
        self.serial_number = serial_number
        self._rates = (baudrate,) if baudrate else DEVICE_RATES
        self.baudrate = self._rates[0]
        """The rate in use (the one the device answered at, once open)."""
        self._open_stream = open_stream or (lambda p: open_serial(p, self.baudrate))
        self.reconnect = reconnect
        self.command_timeout = command_timeout
        self.retries = retries
        self.open_timeout = open_timeout
        self.name = name or port or serial_number or "fingertip"
        self._counters = BridgeStats()
        self.clock = ClockSync()
        self.settings = Settings()
        self._decoder = StreamDecoder("device")
        self._stream: ByteStream | None = None
        # No queue when nobody reads it: it would only count made-up overruns.
        self._queue: deque[Frame] | None = deque(maxlen=queue_size) if queue_size else None
        self._shared = reader
        self._cond = threading.Condition()
        self._callbacks: list[Callable[[Frame], None]] = []
        self._pending: deque[_Pending] = deque()
        self._pending_lock = threading.Lock()
        self._write_lock = threading.Lock()
        self._request_ids = itertools.cycle(range(1, 0x10000))
        self._info: Info | None = None
        self._device_stats: Stats | None = None
        self._status = "closed"
        self._ever_opened = False
        self._lost_for_good = False
        self._connected = threading.Event()
        self._closing = threading.Event()
        self._reader: threading.Thread | None = None
        self._restore_needed = threading.Event()
        self._restorer: threading.Thread | None = None
        # After a reconnect, frames wait in _held until the device on the port proves to be
        # the one opened (same firmware, build and channels): a path can be taken by another
        # device meanwhile (a pty number reused, another board on /dev/ttyACM0).
        self._identity: tuple | None = None
        self._verifying = False
        self._held: deque[Frame] = deque(maxlen=1024)
        self._verdict: tuple[int, str] | None = None  # (connection, "ok" | "foreign")
        self._connection = 0  # counts connections, so that a verdict meets its own
        self.port = ""

    # --- opening and closing --------------------------------------------------------------

    def open(self) -> Fingertip:
        """Connect, check the protocol version, and learn the device's set-up. Without a
        ``baudrate``, each of :data:`DEVICE_RATES` is tried until the device answers (a
        wrong rate, where no frame decodes, costs ``open_timeout``)."""
        if self._status != "closed":
            return self
        for k, rate in enumerate(self._rates):
            self.baudrate = rate
            try:
                return self._open_at_rate()
            except CommandTimeout:
                # Whole frames decoded: the rate is right and the device is only slow.
                if k + 1 == len(self._rates) or self._decoder.stats.frames_ok:
                    raise
                log.info("%s: no answer at %d baud, trying %d", self.name, rate,
                         self._rates[k + 1])
        raise AssertionError("no rates to try")

    def _open_at_rate(self) -> Fingertip:
        self._closing.clear()
        self._connect_once()  # raises TransportError with a clear message
        self._status = "connected"
        self._ever_opened = True
        self._lost_for_good = False
        self._start_own_reader()
        self._restorer = threading.Thread(target=self._restore_loop, daemon=True,
                                          name=f"fingertip-restore-{self.name}")
        self._restorer.start()
        try:
            info = self._handshake(self.open_timeout)
        except BaseException:
            self.close()
            raise
        self.settings = Settings(info.rate_sps, info.decimation, info.gain, info.tare_offsets,
                                 info.streaming)
        self._identity = _identity(info)
        return self

    def close(self) -> None:
        """Stop the threads and release the port. Pending commands fail with NotConnected."""
        self._closing.set()
        self._status = "closed"
        self._connected.clear()
        self._restore_needed.set()
        if self._shared is not None:
            self._shared.remove(self)  # it no longer reads the stream closed below
        for t in (self._reader, self._restorer):
            if t and t is not threading.current_thread():
                t.join(timeout=2)
        self._reader = self._restorer = None
        self._release_stream()
        self._fail_pending()
        with self._cond:
            self._cond.notify_all()

    def __enter__(self) -> Fingertip:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _resolve_port(self) -> str:
        if self._port_arg is not None:
            return self._port_arg
        assert self.serial_number is not None
        return find_port(self.serial_number).device

    def _connect_once(self) -> None:
        port = self._resolve_port()
        stream = self._open_stream(port)
        self._stream = stream
        self.port = port
        self._connection += 1
        self._held.clear()  # frames of an earlier connection never reach a later one
        self._decoder.reset()
        self.clock.reset()
        self._connected.set()

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

    # --- state ----------------------------------------------------------------------------

    @property
    def stats(self) -> BridgeStats:
        """Counters of everything the host saw and lost (a snapshot)."""
        d = self._decoder.stats
        c = self._counters
        return BridgeStats(
            frames_ok=d.frames_ok, bytes_in=d.bytes_in, crc_errors=d.crc_errors,
            cobs_errors=d.cobs_errors, length_errors=d.too_short + d.too_long,
            unknown_type=d.unknown_type, bad_payload=d.bad_payload, seq_gaps=d.seq_gaps,
            frames_lost=d.frames_lost,
            overruns=c.overruns, reconnects=c.reconnects, device_resets=c.device_resets,
            callback_errors=c.callback_errors, command_retries=c.command_retries,
            log_lines=c.log_lines, foreign_devices=c.foreign_devices)

    @property
    def status(self) -> str:
        """``"connected"``, ``"reconnecting"`` or ``"closed"``."""
        return self._status

    @property
    def info(self) -> Info:
        if self._info is None:
            raise NotConnected(f"{self.name} is not open")
        return self._info

    @property
    def channels(self) -> int:
        return self.info.channels

    # --- frames ---------------------------------------------------------------------------

    def _not_open(self) -> NotConnected:
        """Why nothing can be read or sent now, as the exception to raise."""
        if self._lost_for_good:
            why = "lost its device and reconnect is off: open() it again"
        elif self._ever_opened:
            why = "is closed: open() it again to use it"
        else:
            why = "was never opened: call open() first (or use `with Fingertip(...)`)"
        return NotConnected(f"{self.name} {why}")

    def _no_queue(self) -> FingertipError:
        return FingertipError(f"{self.name} was made with queue_size=0: its frames go to "
                              f"callbacks only (add_callback), nothing queues them to read")

    def read(self, timeout: float | None = None) -> Frame | None:
        """The next frame, or None after ``timeout`` seconds without one.

        Frames received before a close are still handed out; after them, reading a closed
        (or never opened) device raises :class:`NotConnected` instead of returning None like
        a timeout, so that a loop cannot spin on a dead device.
        """
        if timeout is not None and not timeout >= 0:
            raise ValueError(f"timeout must be >= 0 seconds (or None), not {timeout!r}")
        if self._queue is None:
            raise self._no_queue()
        with self._cond:
            if not self._queue:
                if self._status == "closed":
                    raise self._not_open()
                self._cond.wait(timeout)
                if not self._queue and self._status == "closed":
                    raise self._not_open()
            return self._queue.popleft() if self._queue else None

    def frames(self, timeout: float | None = None) -> Iterator[Frame]:
        """Iterate over frames until ``timeout`` passes without one; ends (without an
        error) when the device is closed meanwhile, after the frames it had received."""
        while True:
            try:
                f = self.read(timeout)
            except NotConnected:
                if self._ever_opened and not self._lost_for_good:
                    return
                raise
            if f is None:
                return
            yield f

    def drain(self) -> list[Frame]:
        """All frames queued so far, without waiting."""
        if self._queue is None:
            raise self._no_queue()
        with self._cond:
            out = list(self._queue)
            self._queue.clear()
        return out

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
            raise ValueError(f"rate must be one of {', '.join(map(str, VALID_RATES))} SPS "
                             f"(the HX711's RATE pin), not {rate_sps!r}")
        decimation = check_int("decimation", decimation, 1, 255)
        self._command(SetRate(0, rate_sps, decimation))
        self.settings.rate_sps, self.settings.decimation = rate_sps, decimation

    def set_gain(self, gain: int) -> None:
        if gain not in VALID_GAINS:
            raise ValueError(f"gain must be one of {', '.join(map(str, VALID_GAINS))}, "
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
            mask = 0
            for c in channels:
                if not 0 <= c < n:
                    raise ValueError(f"channel {c} does not exist (this device has {n})")
                mask |= 1 << c
            if not mask:
                raise ValueError("tare needs at least one channel (an empty list was given)")
        s = self.settings
        wait = samples * s.decimation / s.rate_sps * 1.6 + 0.5
        self._command(Tare(0, mask, samples), timeout=wait, retries=0)
        offsets = self.get_info().tare_offsets
        self.settings.offsets = offsets
        return offsets

    def set_tare_offsets(self, offsets: list[int] | tuple[int, ...]) -> None:
        """Put known offsets (one per channel) back on the device."""
        if len(offsets) != self.channels:
            raise ValueError(f"need {self.channels} offsets, got {len(offsets)}")
        offsets = tuple(check_int("a tare offset", v, INT24_MIN, INT24_MAX) for v in offsets)
        padded = tuple(offsets) + (0,) * (MAX_CHANNELS - len(offsets))
        self._command(SetTareOffsets(0, (1 << len(offsets)) - 1, padded))
        self.settings.offsets = tuple(offsets)

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
        pending = _Pending(cmd)
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
                    if res is None:
                        raise NotConnected(f"{self.name}: closed while waiting for {name}")
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
        raise CommandTimeout(f"{self.name}: no answer to {name} within {timeout:.2f} s "
                             f"({retries + 1} attempts)")

    def _write(self, data: bytes) -> None:
        # The stream is taken under the lock that its closing also holds (_release_stream):
        # a command thread (the restorer's GET_INFO) must never write into a port that the
        # reader is closing after a loss; pyserial then failed with a TypeError that killed
        # the restorer for good, and the device was never taken back.
        with self._write_lock:
            stream = self._stream
            if stream is None:
                raise TransportError("not open")
            stream.write(data)

    def _release_stream(self) -> None:
        """Detach and close the stream, never in the middle of a write."""
        with self._write_lock:
            stream, self._stream = self._stream, None
        if stream:
            stream.close()

    def _fail_pending(self) -> None:
        with self._pending_lock:
            for p in self._pending:
                p.done.set()
            self._pending.clear()

    # --- reader thread --------------------------------------------------------------------

    def _start_own_reader(self) -> None:
        """Read on a thread of this device's own (always without a shared reader; with one,
        while it connects, reconnects or proves its identity)."""
        if self._closing.is_set():
            return
        self._reader = threading.Thread(target=self._read_loop, daemon=True,
                                        name=f"fingertip-reader-{self.name}")
        self._reader.start()

    def _read_loop(self) -> None:
        while not self._closing.is_set():
            if self._verdict is not None:
                self._apply_verdict()
            stream = self._stream
            if stream is None:
                self._reconnect()
                continue
            if self._shared is not None and not self._verifying and self._verdict is None:
                fd = stream_fileno(stream)
                if fd is not None:  # streaming steadily: the shared thread reads from now on
                    self._shared.add(self, fd)
                    return
            try:
                # The timeout only bounds how long close() waits: data wakes the read at once.
                data = stream.read(4096, timeout=0.1)
            except TransportError as e:
                if self._closing.is_set():
                    return
                log.warning("%s: lost the device (%s); reconnecting", self.name, e)
                self._lost()
                continue
            if data:
                self._handle_bytes(data, time.monotonic())

    def _read_available(self) -> None:
        """On the shared reader's thread, the port being readable: take what came."""
        stream = self._stream
        if stream is None:
            return
        ready = getattr(stream, "read_ready", None)
        data = ready(4096) if ready is not None else stream.read(4096, timeout=0)
        if data:
            self._handle_bytes(data, time.monotonic())

    def _lost_on_shared(self, e: TransportError) -> None:
        """The shared reader lost this device's port: reconnect on a thread of its own."""
        if self._closing.is_set():
            return
        log.warning("%s: lost the device (%s); reconnecting", self.name, e)
        self._lost()
        self._start_own_reader()

    def _lost(self) -> None:
        self._connected.clear()
        self._status = "reconnecting"
        self._release_stream()
        self._fail_pending()
        if not self.reconnect:
            self._lost_for_good = True
            self._status = "closed"
            self._closing.set()
            with self._cond:
                self._cond.notify_all()

    def _reconnect(self) -> None:
        while not self._closing.is_set():
            try:
                self._connect_once()
            except (TransportError, LookupError, OSError) as e:
                log.debug("%s: reconnect failed: %s", self.name, e)
                self._closing.wait(0.05)
                continue
            self._counters.reconnects += 1
            self._verifying = self._identity is not None
            self._status = "connected"
            self._restore_needed.set()
            log.info("%s: reconnected on %s", self.name, self.port)
            return

    def _handle_bytes(self, data: bytes, arrival: float) -> None:
        for msg in self._decoder.feed(data):
            if isinstance(msg, Sample):
                self._on_sample(msg, arrival)
            elif isinstance(msg, (Ack, Nack)):
                self._on_answer(msg)
            elif isinstance(msg, (Info, ForeignInfo)):
                self._on_info(msg)
            elif isinstance(msg, Stats):
                self._device_stats = msg
                self._attach(msg, GetStats)
            elif isinstance(msg, Log):
                self._counters.log_lines += 1
                log.log(10 + 10 * min(msg.level, 3), "%s device: %s", self.name, msg.text)

    def _on_sample(self, msg: Sample, arrival: float) -> None:
        # The frame left the device after its last byte crossed the UART: take that transit
        # time (10 bits a byte, COBS byte and delimiter included) out of the arrival time,
        # so that the clock map lands on the moment the chips were ready.
        transit = (16 + 3 * len(msg.values)) * 10 / self.baudrate
        d = self.clock.observe(msg.timestamp_us, arrival - transit)
        frame = Frame(msg.seq, d, self.clock.to_host(d), arrival, msg.values,
                      msg.timeout_mask, msg.saturation_mask)
        if self._verifying:  # not handed out before the device is known to be ours
            if len(self._held) == self._held.maxlen:
                self._counters.overruns += 1
            self._held.append(frame)
            return
        self._deliver(frame)

    def _deliver(self, frame: Frame) -> None:
        queue = self._queue
        if queue is not None:
            with self._cond:
                if len(queue) == queue.maxlen:
                    self._counters.overruns += 1
                queue.append(frame)
                self._cond.notify()
        for cb in self._callbacks:
            try:
                cb(frame)
            except Exception:  # a user callback must not kill the reader
                self._counters.callback_errors += 1
                log.exception("%s: frame callback failed", self.name)

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

    def _on_info(self, msg: Info | ForeignInfo) -> None:
        if isinstance(msg, Info) and msg.is_boot:
            if self._info is not None:
                self._counters.device_resets += 1
                log.warning("%s: the device reset (cause 0x%02X); restoring its set-up",
                            self.name, msg.reset_cause)
                self.clock.reset()
                self._restore_needed.set()
            return
        self._attach(msg, GetInfo)

    # --- restoring the set-up after a reconnect or reset ----------------------------------

    def _restore_loop(self) -> None:
        while True:
            self._restore_needed.wait()
            if self._closing.is_set():
                return
            self._restore_needed.clear()
            try:
                self._restore()
            except (FingertipError, TransportError) as e:
                if self._closing.is_set():
                    return
                log.warning("%s: restoring the set-up failed (%s); will retry", self.name, e)
                self._closing.wait(0.1)
                self._restore_needed.set()

    def _apply_verdict(self) -> None:
        """On the reader thread: release the held frames, or drop the foreign device."""
        (connection, verdict), self._verdict = self._verdict, None
        if connection != self._connection:
            return  # about a connection that is gone
        held = list(self._held)
        self._held.clear()
        if verdict == "foreign":
            self._lost()
            return
        self._verifying = False
        for f in held:
            self._deliver(f)

    def _restore(self) -> None:
        want = self.settings
        connection = self._connection
        info = self._handshake(self.open_timeout)
        if self._identity is not None and _identity(info) != self._identity:
            self._counters.foreign_devices += 1
            self._verdict = (connection, "foreign")
            raise FingertipError(
                f"{self.name}: the device now on {self.port} is not the one opened (firmware "
                f"{_describe(_identity(info))}, expected {_describe(self._identity)}); "
                f"its frames are dropped and the port is left until the right one returns")
        if self._verifying:
            self._verdict = (connection, "ok")
        if (info.rate_sps, info.decimation) != (want.rate_sps, want.decimation):
            self._command(SetRate(0, want.rate_sps, want.decimation))
        if info.gain != want.gain:
            self._command(SetGain(0, want.gain))
        if want.offsets and any(want.offsets) and info.tare_offsets != want.offsets:
            padded = tuple(want.offsets) + (0,) * (MAX_CHANNELS - len(want.offsets))
            self._command(SetTareOffsets(0, (1 << len(want.offsets)) - 1, padded))
        if want.streaming and not info.streaming:
            self._command(Start())
        log.info("%s: set-up restored", self.name)
