"""Starting child processes from tests.

A suite started as a background job of a script (``make test &``, nohup) has SIGINT
*ignored*, and children inherit that: a test that stops a child with SIGINT would wait for
ever. :func:`default_signals` (a ``preexec_fn``) gives the child the default handlers back.
"""
from __future__ import annotations

import signal


def default_signals() -> None:
    """``preexec_fn`` of a child that tests stop with a signal: default SIGINT and SIGHUP."""
    for s in (signal.SIGINT, signal.SIGHUP):
        signal.signal(s, signal.SIG_DFL)
