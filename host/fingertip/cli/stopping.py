"""How a command ends: the stop signals it answers, and the one place where an exception
becomes one line and an exit status.

:func:`stop_signals` installs, explicitly, handlers for SIGINT, SIGTERM and SIGHUP, so a
command stops the same way however it was started (a background job of a script inherits
SIGINT *ignored*; Python then never raises KeyboardInterrupt). The first signal raises
:class:`Interrupted` (a KeyboardInterrupt: every loop that ends cleanly at Ctrl-C ends
cleanly at SIGTERM and SIGHUP too); later ones are ignored while the command closes its
files. :func:`run_command` maps whatever the command raises through
:func:`fingertip.errors.exit_code` and :func:`fingertip.errors.describe`.
"""
from __future__ import annotations

import contextlib
import logging
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from typing import Any

from ..errors import EXIT_INTERRUPTED, describe, exit_code

log = logging.getLogger("fingertip")

STOP_SIGNALS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP")
                     if hasattr(signal, n))


FORMAT = "%(levelname)s %(name)s: %(message)s"


def configure_logging(verbose: int | None = None) -> None:
    """Log lines as ``ERROR fingertip: ...`` on stderr, at WARNING (``verbose``: INFO, DEBUG),
    unless the caller (an in-process user, a test) set up logging already; called before
    anything can fail, so even an interrupt during start-up is reported."""
    root = logging.getLogger()
    ours = getattr(root, "_fingertip_cli", False)
    if not root.handlers:
        logging.basicConfig(format=FORMAT)
        root._fingertip_cli = ours = True  # type: ignore[attr-defined]
    if ours and verbose is not None:
        root.setLevel(logging.WARNING - 10 * min(verbose, 2))


class Interrupted(KeyboardInterrupt):
    """A stop signal arrived; ``signame`` says which (SIGINT, SIGTERM, SIGHUP)."""

    def __init__(self, signame: str) -> None:
        super().__init__(signame)
        self.signame = signame


_raised = threading.Event()
_signame = ["SIGINT"]  # the stop signal that was raised (once _raised is set)
_putting_back = threading.Event()  # stop_signals is putting the old handlers back


def _on_signal(signum: int, _frame: Any) -> None:
    if _raised.is_set():
        log.debug("%s while stopping: ignored", signal.Signals(signum).name)
        return
    _signame[0] = signal.Signals(signum).name
    _raised.set()
    if not _putting_back.is_set():  # else raised once every handler is back
        raise Interrupted(_signame[0])


@contextlib.contextmanager
def stop_signals() -> Iterator[None]:
    """Inside, SIGINT, SIGTERM and SIGHUP raise :class:`Interrupted` once; the previous
    handlers are back on the way out. Does nothing off the main thread (Python handles
    signals there only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _raised.clear()
    # Taken before any goes in: a signal may come as they do, and its handler then raises
    # on the next bytecode, before signal.signal has returned the old one.
    old = {s: signal.getsignal(s) for s in STOP_SIGNALS}
    try:
        for s in STOP_SIGNALS:
            signal.signal(s, _on_signal)
        yield
    finally:
        # A signal while they go back is only noted (raising would leave the rest ours),
        # and raised once all are back.
        raised_before = _raised.is_set()
        _putting_back.set()
        try:
            for s, h in old.items():
                signal.signal(s, h if h is not None else signal.SIG_DFL)
        finally:
            _putting_back.clear()
        if _raised.is_set() and not raised_before:
            raise Interrupted(_signame[0])


def interrupted(e: KeyboardInterrupt, verbose: int = 0) -> int:
    """Say which signal stopped the command; exit status 130."""
    log.error("interrupted by %s: stopped before the end", getattr(e, "signame", "SIGINT"),
              exc_info=verbose > 0)
    return EXIT_INTERRUPTED


def run_command(fn: Callable[[Any], int], args: Any, verbose: int = 0) -> int:
    """``fn(args)``'s exit status; an exception becomes one ERROR line (with the traceback
    at ``-v``) and :func:`~fingertip.errors.exit_code`'s status: 2 the user's input, 1 a
    failure, 130 interrupted."""
    try:
        return int(fn(args))
    except KeyboardInterrupt as e:
        return interrupted(e, verbose)
    except BrokenPipeError:  # `fingertip ... | head`: the reader left, which is fine
        with contextlib.suppress(OSError, ValueError, AttributeError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except Exception as e:  # noqa: BLE001 - the one place every error becomes one line
        return failed(e, verbose)


def failed(e: Exception, verbose: int = 0) -> int:
    """One ERROR line for ``e`` and its exit status. An interrupt that a library turned into
    another exception (numpy makes an ImportError of a Ctrl-C during its import, and a
    signal inside its C extension's start-up leaves no trace in the chain) is still an
    interrupt: found in the chain, or by the stop signal raised meanwhile."""
    seen: BaseException | None = e
    for _ in range(10):
        seen = seen.__cause__ or seen.__context__ if seen is not None else None
        if isinstance(seen, KeyboardInterrupt):
            return interrupted(seen, verbose)
    if _raised.is_set():
        log.warning("while stopping: %s", describe(e), exc_info=verbose > 0)
        return interrupted(Interrupted(_signame[0]), verbose)
    log.error("%s", describe(e), exc_info=verbose > 0)
    return exit_code(e)
