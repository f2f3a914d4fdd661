"""Serve a :class:`VirtualFirmware` on a pseudo-terminal, in real time.

The host opens the pty's path with pyserial exactly as it opens a USB serial port, so the
bridge, the CLI and the tests run unchanged against it. A stable symlink (like udev's
/dev/serial/by-id links) survives :meth:`PtyDevice.unplug` / :meth:`PtyDevice.replug`, which
close the pty and make a new one, as a USB cable pulled and pushed back in would.
"""
from __future__ import annotations

import contextlib
import logging
import os
import select
import termios
import threading
import time
import tty
from collections.abc import Iterator
from pathlib import Path

from .virtual_firmware import VirtualFirmware

IDLE_POLL_S = 0.05
"""Longest sleep of the serving loop (how long stop() may wait)."""
WAKE_MARGIN_S = 1e-4
"""Wake this much after a due conversion, so that the device clock has passed it."""

log = logging.getLogger(__name__)


class PtyDevice:
    """A virtual fingertip behind a pty. Use as a context manager or call start/stop.

    ``link``: a path to keep pointing at the current pty (optional). ``speed``: device
    seconds per wall second. ``clock_skew_ppm``: how fast the device clock runs relative to
    the host's (a real resonator is tens to hundreds of ppm off).
    """

    def __init__(self, firmware: VirtualFirmware | None = None, *, link: str | Path | None = None,
                 speed: float = 1.0, clock_skew_ppm: float = 0.0,
                 clock_offset_us: int = 0) -> None:
        self.firmware = firmware or VirtualFirmware()
        self.link = Path(link) if link else None
        self.speed = speed
        self.clock_skew = clock_skew_ppm * 1e-6
        self.clock_offset_us = clock_offset_us
        self._lock = threading.Lock()
        self._master: int | None = None
        self._slave: int | None = None
        self.port: str = ""
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._t0 = 0.0
        self.bytes_out = 0
        self.bytes_in = 0
        self.bytes_dropped = 0

    # --- life cycle -----------------------------------------------------------------------

    def start(self) -> PtyDevice:
        self._open_pty()
        self._boot()
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="pty-device", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread:
            self._thread.join(timeout=2)
            self._thread = None
        self._close_pty()
        if self.link and self.link.is_symlink():
            self.link.unlink()

    def __enter__(self) -> PtyDevice:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    @contextlib.contextmanager
    def held(self) -> Iterator[None]:
        """Hold the serving loop for the block, as a loop the scheduler wakes late does:
        nothing is read or sent meanwhile, and the conversions that fell due are served
        when it ends."""
        with self._lock:
            yield

    def unplug(self) -> None:
        """Close the pty: the host sees its port vanish (reads fail, the path is gone). The
        device runs on meanwhile, and what it sends is lost (``bytes_dropped``), as on an
        unplugged cable."""
        with self._lock:
            self._close_pty()

    def replug(self, reboot: bool = True) -> None:
        """A new pty (a new /dev/pts path; the link follows). ``reboot``: the device resets,
        as one does when USB power returns."""
        with self._lock:
            self._close_pty()
            # What fell due while unplugged went nowhere: it must not wait in the new pty
            # for the host, who would read frames of the outage as if they had come late.
            self._write(self.firmware.advance(self._device_us()))
            self._open_pty()
            if reboot:
                self._boot()

    def reset(self) -> None:
        """Reset the device (as the DTR pulse or the reset button does) on the same port."""
        with self._lock:
            self._boot()

    # --- internals ------------------------------------------------------------------------

    def device_time_s(self, host_time: float) -> float:
        """Device seconds at ``host_time`` (a ``time.monotonic()`` value)."""
        return (self.clock_offset_us * 1e-6
                + (host_time - self._t0) * self.speed * (1 + self.clock_skew))

    def _device_us(self) -> int:
        elapsed = (time.monotonic() - self._t0) * self.speed * (1 + self.clock_skew)
        return self.clock_offset_us + int(elapsed * 1e6)

    def _boot(self) -> None:
        self._t0 = time.monotonic()
        self._write(self.firmware.boot(start_us=self.clock_offset_us))

    def _open_pty(self) -> None:
        master, slave = os.openpty()
        tty.setraw(slave)
        attrs = termios.tcgetattr(slave)
        attrs[3] &= ~termios.ECHO
        termios.tcsetattr(slave, termios.TCSANOW, attrs)
        os.set_blocking(master, False)
        self._master, self._slave = master, slave
        self.port = os.ttyname(slave)
        if self.link:
            tmp = self.link.with_name(self.link.name + ".new")
            if tmp.is_symlink() or tmp.exists():
                tmp.unlink()
            tmp.symlink_to(self.port)
            tmp.replace(self.link)

    def _close_pty(self) -> None:
        for fd in (self._master, self._slave):
            if fd is not None:
                try:
                    os.close(fd)
                except OSError:
                    pass
        self._master = self._slave = None
        if self.link and self.link.is_symlink():
            self.link.unlink()

    def _write(self, data: bytes) -> None:
        if not data:
            return
        if self._master is None:  # unplugged: the bytes go nowhere
            self.bytes_dropped += len(data)
            return
        view = memoryview(data)
        while view:
            try:
                n = os.write(self._master, view)
            except BlockingIOError:
                # Nobody reads and the pty buffer is full: a UART without flow control loses
                # these bytes too, so drop them (counted) rather than stall the device.
                self.bytes_dropped += len(view)
                return
            except OSError:
                self.bytes_dropped += len(view)
                return
            self.bytes_out += n
            view = view[n:]

    def _run(self) -> None:
        while not self._stop.is_set():
            with self._lock:
                master = self._master
                due = self.firmware.next_due_us
            if master is None:  # unplugged: the device runs on, its output lost
                with self._lock:
                    self._write(self.firmware.advance(self._device_us()))
                time.sleep(0.01)
                continue
            # Sleep until the device's next conversion (or a byte from the host): a fixed
            # short poll would wake this process hundreds of times a second for nothing, and
            # on a shared machine those wake-ups cost the bridge under test its caches.
            timeout = IDLE_POLL_S if due is None else min(max(
                (due - self._device_us()) / (1e6 * self.speed * (1 + self.clock_skew))
                + WAKE_MARGIN_S, 0.0), IDLE_POLL_S)
            try:
                ready, _, _ = select.select([master], [], [], timeout)
            except (OSError, ValueError):
                continue
            with self._lock:
                if self._master is None:
                    continue
                if ready:
                    try:
                        data = os.read(self._master, 4096)
                    except BlockingIOError:
                        data = b""
                    except OSError:  # no client has the slave open: nothing to read
                        data = b""
                    if data:
                        self.bytes_in += len(data)
                        # What fell due before the command goes out first: dropping it
                        # lost the samples (their sequence numbers used) whenever a command
                        # met a late wake-up, as under CPU load.
                        self._write(self.firmware.advance(self._device_us()))
                        self._write(self.firmware.receive(data))
                self._write(self.firmware.advance(self._device_us()))


def virtual_fingertip_ports(n: int, seed: int, stack: contextlib.ExitStack) -> list[str]:
    """Start ``n`` idle 4-channel virtual fingertips (unit ``seed + i`` each), each on its
    own pty closed with ``stack``, and return their ports."""
    from ..physics import Idle, VirtualStrainSensor

    ports = []
    for i in range(n):
        src = VirtualStrainSensor(seed + i).as_source(Idle(duration=1e9))
        dev = stack.enter_context(PtyDevice(VirtualFirmware(4, source=src)))
        ports.append(dev.port)
    return ports
