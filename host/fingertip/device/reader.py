"""``SharedReader``: one thread that reads the ports of several fingertips.

A thread per device wakes once per frame: four fingertips at 80 Hz are 320 wake-ups a
second spread over four threads that pass the GIL back and forth. One thread waiting on
all ports (``selectors``) takes the bytes of every port that has some in one wake-up, on
warm caches, and leaves fewer threads to contend for the GIL.

Only the steady state is shared: a device whose stream has no file descriptor, or that is
reconnecting or proving its identity after a reconnect, runs its own reader thread (as a
lone :class:`~fingertip.device.Fingertip` does) and comes back here once it streams again.
"""
from __future__ import annotations

import logging
import os
import selectors
import threading
from typing import Any, Protocol

from ..transport import TransportError

log = logging.getLogger(__name__)


class SharedDevice(Protocol):
    """What the shared reader asks of a device it reads (a
    :class:`~fingertip.device.Fingertip` offers it)."""

    def read_available(self) -> None:
        """Take the bytes its readable port holds, without waiting."""

    def read_failed(self, error: TransportError) -> None:
        """Its port failed while the shared thread read it (already dropped from it):
        recover on a thread of its own."""

    @property
    def needs_own_reader(self) -> bool:
        """It must go back to a thread of its own for now (a verdict on its identity)."""

    def start_own_reader(self) -> None:
        """Read its port on a thread of its own from now on."""


def stream_fileno(stream: Any) -> int | None:
    """The descriptor to wait on for ``stream``, or None when it has none."""
    get = getattr(stream, "fileno", None)
    if get is None:
        return None
    try:
        fd = get()
    except (OSError, ValueError):
        return None
    return fd if isinstance(fd, int) and fd >= 0 else None


class SharedReader:
    """Read the ports of the fingertips given to it on one thread (started with the first,
    ended when none is left). Give it to each :class:`Fingertip` as ``reader=``."""

    def __init__(self, name: str = "fingertip-reader-shared") -> None:
        self.name = name
        self._lock = threading.Lock()
        self._changes: list[tuple[str, SharedDevice, int, threading.Event]] = []
        self._members: dict[int, SharedDevice] = {}  # fd -> device; the reader thread's own
        self._thread: threading.Thread | None = None
        self._wake_r, self._wake_w = os.pipe()
        os.set_blocking(self._wake_r, False)
        self.wakeups = 0
        """Times the thread woke with data (a figure for benchmarks and tests)."""

    def add(self, ft: SharedDevice, fd: int) -> None:
        """Read ``ft``'s port (descriptor ``fd``) here from now on; returns at once."""
        self._change("add", ft, fd, wait=False)

    def remove(self, ft: SharedDevice) -> None:
        """Stop reading ``ft``; once this returns, this thread no longer touches its stream."""
        self._change("remove", ft, -1, wait=True)

    def _change(self, what: str, ft: SharedDevice, fd: int, wait: bool) -> None:
        done = threading.Event()
        with self._lock:
            self._changes.append((what, ft, fd, done))
            if self._thread is None or not self._thread.is_alive():
                self._thread = threading.Thread(target=self._run, daemon=True, name=self.name)
                self._thread.start()
            own = self._thread is threading.current_thread()
        if own:  # from a callback on this thread: apply now, do not wait for ourselves
            self._apply_changes(self._sel_for_self)
            return
        os.write(self._wake_w, b"x")
        if wait:
            done.wait()

    def _apply_changes(self, sel: selectors.BaseSelector) -> None:
        with self._lock:
            changes, self._changes = self._changes, []
        for what, ft, fd, done in changes:
            if what == "add":
                self._members[fd] = ft
                sel.register(fd, selectors.EVENT_READ, ft)
            else:
                for mfd, m in list(self._members.items()):
                    if m is ft:
                        self._drop(sel, mfd)
            done.set()

    def _drop(self, sel: selectors.BaseSelector, fd: int) -> None:
        self._members.pop(fd, None)
        try:
            sel.unregister(fd)
        except (KeyError, ValueError, OSError):
            pass

    def _run(self) -> None:
        sel = selectors.DefaultSelector()
        self._sel_for_self = sel
        sel.register(self._wake_r, selectors.EVENT_READ, None)
        try:
            while True:
                self._apply_changes(sel)
                with self._lock:
                    if not self._members and not self._changes:
                        self._thread = None  # the next add starts a new thread
                        return
                # The timeout only bounds how soon a verdict (see below) is looked at.
                events = sel.select(0.1)
                for key, _ in events:
                    ft = key.data
                    if ft is None:
                        try:
                            os.read(self._wake_r, 512)
                        except BlockingIOError:
                            pass
                        continue
                    if key.fd not in self._members:
                        continue  # dropped earlier in this same wake-up
                    self.wakeups += 1
                    try:
                        ft.read_available()
                    except TransportError as e:
                        self._drop(sel, key.fd)  # before the stream closes under the fd
                        ft.read_failed(e)
                for fd, ft in list(self._members.items()):
                    if ft.needs_own_reader:  # a foreign device or a release: its own
                        self._drop(sel, fd)  # thread applies it, as after a reconnect
                        ft.start_own_reader()
        except Exception:  # never leave the devices unread without saying why
            log.exception("%s: the shared reader failed; its devices read on their own",
                          self.name)
            for fd, ft in list(self._members.items()):
                self._drop(sel, fd)
                ft.start_own_reader()
            with self._lock:
                self._thread = None
        finally:
            sel.close()

    def close(self) -> None:
        """Release the wake-up pipe (after every device was removed)."""
        for fd in (self._wake_r, self._wake_w):
            try:
                os.close(fd)
            except OSError:
                pass
