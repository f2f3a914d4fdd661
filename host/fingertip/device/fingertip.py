"""``Fingertip``: one device, its commands, its frame stream, its counters, its clock.

A background thread reads the port (its own, or one :class:`SharedReader` for several
devices), decodes frames, maps device time to host time and hands frames to a bounded queue
(none with ``queue_size=0``, for consumers that take frames by callback) and to callbacks.
Commands wait for their ACK or NACK. When the port vanishes (cable pulled, pty closed,
simulator restarted) or the device resets, the thread reconnects by itself, re-applies
rate, gain and tare offsets and resumes streaming, and counts it; user loops only ever see
it through :attr:`Fingertip.status`.

This module holds the device's life cycle, its state and its frame path (bytes -> messages
-> frames -> queue and callbacks); the other parts are mixed in from their own modules:
commands (:mod:`.commands`), the port and its reader thread (:mod:`.link`), and taking the
device back after a reconnect or reset (:mod:`.restore`).
"""
from __future__ import annotations

import itertools
import logging
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator

from ..errors import EXIT_FAILED, BadArgumentError
from ..protocol import (
    Ack, ForeignInfo, GetInfo, GetStats, Info, Log, Nack, Sample, Stats, StreamDecoder,
)
from ..transport import ByteStream, open_serial
from .commands import DeviceCommands, PendingCommand
from .errors import CommandTimeout, FingertipError, NotConnected, check_int
from .frames import Frame, FrameSource
from .link import PortLink
from .outage import OutageTracker
from .reader import SharedReader
from .restore import SetupRestore, identity
from .state import BridgeStats, Settings
from .timesync import ClockSync

log = logging.getLogger(__name__)

DEVICE_RATES = (1_000_000, 115_200)
"""UART rates a fingertip's firmware runs at, the current default first (exact at 16 MHz;
firmware built before 1 Mbaud became the default runs at 115200): with ``baudrate=None``,
:meth:`Fingertip.open` tries each in turn until the device answers."""

StreamFactory = Callable[[str], ByteStream]


class Fingertip(DeviceCommands, PortLink, SetupRestore, FrameSource):
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
            raise BadArgumentError("give exactly one of port or serial_number")
        check_int("queue_size", queue_size, 0, 1 << 24)
        check_int("retries", retries, 0, 100)
        if baudrate is not None:
            check_int("baudrate", baudrate, 1, 10_000_000)
        for what, v in (("command_timeout", command_timeout), ("open_timeout", open_timeout)):
            if not (isinstance(v, int | float) and 0 < v < float("inf")):
                raise BadArgumentError(f"{what} must be a positive number of seconds, not {v!r}")
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
        self._outages = OutageTracker()
        self.clock = ClockSync()
        self.settings = Settings()
        self._decoder = StreamDecoder("device")
        self._stream: ByteStream | None = None
        # No queue when nobody reads it: it would only count made-up overruns.
        self._queue: deque[Frame] | None = deque(maxlen=queue_size) if queue_size else None
        self._shared = reader
        self._cond = threading.Condition()
        self._callbacks: list[Callable[[Frame], None]] = []
        self._pending: deque[PendingCommand] = deque()
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
        self.start_own_reader()
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
        self._identity = identity(info)
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

    # --- state ----------------------------------------------------------------------------

    @property
    def stats(self) -> BridgeStats:
        """Counters of everything the host saw and lost (a snapshot)."""
        d = self._decoder.stats
        c, o = self._counters, self._outages
        return BridgeStats(
            frames_ok=d.frames_ok, bytes_in=d.bytes_in, crc_errors=d.crc_errors,
            cobs_errors=d.cobs_errors, length_errors=d.too_short + d.too_long,
            unknown_type=d.unknown_type, bad_payload=d.bad_payload, seq_gaps=d.seq_gaps,
            frames_lost=d.frames_lost + o.outage_frames, outage_frames=o.outage_frames,
            overruns=c.overruns, reconnects=c.reconnects, device_resets=o.device_resets,
            callback_errors=c.callback_errors, command_retries=c.command_retries,
            log_lines=c.log_lines, foreign_devices=c.foreign_devices)

    @property
    def status(self) -> str:
        """``"connected"``, ``"reconnecting"`` or ``"closed"``."""
        return self._status

    @property
    def gone_s(self) -> float | None:
        """Seconds since the last frame while the device is away (lost, not back yet)."""
        return self._outages.gone_for(time.monotonic())

    def _period_s(self) -> float:
        return self.settings.decimation / self.settings.rate_sps

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
        if self._lost_for_good:  # it was streaming, then failed: a failure at run time
            return NotConnected(f"{self.name} lost its device and reconnect is off: open() it "
                                "again", exit_code=EXIT_FAILED)
        if self._ever_opened:
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
            raise BadArgumentError(f"timeout must be >= 0 seconds (or None), not {timeout!r}")
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

    # --- the frame path: bytes -> messages -> frames -> queue and callbacks ---------------

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
        if (gap := self._outages.frame(frame)) is not None:
            log.warning("%s: back after %.2f s: %d frames lost%s", self.name, gap.gone_s,
                        gap.frames_lost, ", the device restarted" * gap.restarted)
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

    def _on_info(self, msg: Info | ForeignInfo) -> None:
        if isinstance(msg, Info) and msg.is_boot:
            if self._info is not None:
                self._outages.reset_seen(self._period_s())
                log.warning("%s: the device reset (cause 0x%02X); restoring its set-up",
                            self.name, msg.reset_cause)
                self.clock.reset()
                self._restore_needed.set()
            return
        self._attach(msg, GetInfo)
