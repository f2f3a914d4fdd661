"""A fingertip's port: opening it, the thread that reads it, and reconnecting when it is lost.

:class:`PortLink` is the link half of :class:`~fingertip.device.Fingertip`. Its reader
thread hands every byte to the device's frame path (``_handle_bytes``); when the device
streams steadily and a :class:`~fingertip.device.reader.SharedReader` was given, that thread
reads the port instead, through the public methods of :class:`~.reader.SharedDevice`
(``read_available``, ``read_failed``, ``needs_own_reader``, ``start_own_reader``), which
this class implements. A lost port fails pending commands and reconnects until ``close``.
"""
from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable

from ..protocol import StreamDecoder
from ..transport import ByteStream, TransportError, find_port
from .frames import Frame
from .outage import OutageTracker
from .reader import SharedReader, stream_fileno
from .state import BridgeStats
from .timesync import ClockSync

log = logging.getLogger(__name__)


class PortLink:
    """The port and reader thread of a :class:`~fingertip.device.Fingertip` (a mixin: the
    attributes below are the device's, set in its ``__init__``; ``_handle_bytes``,
    ``_fail_pending``, ``_apply_verdict`` and the restorer's ``_restore_needed`` are its
    other parts')."""

    name: str
    port: str
    serial_number: str | None
    reconnect: bool
    clock: ClockSync
    _port_arg: str | None
    _open_stream: Callable[[str], ByteStream]
    _stream: ByteStream | None
    _write_lock: threading.Lock
    _decoder: StreamDecoder
    _shared: SharedReader | None
    _reader: threading.Thread | None
    _cond: threading.Condition
    _connected: threading.Event
    _closing: threading.Event
    _restore_needed: threading.Event
    _counters: BridgeStats
    _outages: OutageTracker
    _period_s: Callable[[], float]
    _status: str
    _lost_for_good: bool
    _identity: tuple | None
    _verifying: bool
    _held: deque[Frame]
    _verdict: tuple[int, str] | None
    _connection: int

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

    # --- reader thread --------------------------------------------------------------------

    def start_own_reader(self) -> None:
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

    def read_available(self) -> None:
        """On the shared reader's thread, the port being readable: take what came."""
        stream = self._stream
        if stream is None:
            return
        ready = getattr(stream, "read_ready", None)
        data = ready(4096) if ready is not None else stream.read(4096, timeout=0)
        if data:
            self._handle_bytes(data, time.monotonic())

    def read_failed(self, e: TransportError) -> None:
        """The shared reader lost this device's port: reconnect on a thread of its own."""
        if self._closing.is_set():
            return
        log.warning("%s: lost the device (%s); reconnecting", self.name, e)
        self._lost()
        self.start_own_reader()

    @property
    def needs_own_reader(self) -> bool:
        """A verdict on the device's identity waits (a foreign device, or frames held since
        a reconnect to release): the device's own thread applies it, not a shared one."""
        return self._verdict is not None

    def _lost(self) -> None:
        self._outages.link_lost(self._period_s(), time.monotonic())
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
