"""Run independent jobs (cross-validation folds, member fits) on the machine's cores.

Worker processes are forked, so they inherit what the parent prepared (the windows of every
recording, the candidates) without copying it through a pipe; a job names its inputs by
key and sends back only small results (a fitted model, a fold's answers). Jobs run in rounds
of ``jobs`` at a time: between rounds the caller may stop (a trial that can no longer win)
and the rest is never started. ``jobs`` 1 runs everything in this process, in order: the
results are the same either way (every fit is seeded, and each process uses one BLAS
thread).
"""
from __future__ import annotations

import logging
import multiprocessing
import os
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from typing import Any

log = logging.getLogger(__name__)

_SHARED: dict[str, Any] = {}
"""What the forked workers read: set by :func:`run_rounds` before it forks."""


def default_jobs() -> int:
    """The cores this process may use (``os.cpu_count()``, or fewer when pinned)."""
    n = os.cpu_count() or 1
    try:
        n = min(n, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        pass
    return max(1, n)


def shared(key: str) -> Any:
    """An object the parent shared with the workers (:func:`run_rounds`)."""
    return _SHARED[key]


def _call(fn: Callable[..., Any], args: tuple) -> Any:
    return fn(*args)


def run_rounds(fn: Callable[..., Any], args: Sequence[tuple], jobs: int,
               share: dict[str, Any] | None = None,
               stop: Callable[[list[Any]], bool] | None = None,
               done: Callable[[], None] | None = None) -> list[Any]:
    """``[fn(*a) for a in args]``, ``jobs`` at a time in forked workers (``fn`` a
    module-level function; ``share``: objects the workers read with :func:`shared`).
    ``stop(results so far)`` is asked after each round but the last: True ends the run
    there (the results returned are those of the rounds run). ``done()`` is called after
    each job (a progress bar)."""
    _SHARED.update(share or {})
    out: list[Any] = []
    try:
        if jobs <= 1 or len(args) <= 1 or "fork" not in multiprocessing.get_all_start_methods():
            for i, a in enumerate(args):
                out.append(fn(*a))
                if done is not None:
                    done()
                if stop is not None and i < len(args) - 1 and stop(out):
                    break
            return out
        ctx = multiprocessing.get_context("fork")
        with ProcessPoolExecutor(max_workers=min(jobs, len(args)), mp_context=ctx) as ex:
            step = jobs if stop is not None else len(args)  # rounds only to stop between
            for start in range(0, len(args), step):
                futures = [ex.submit(_call, fn, a) for a in args[start:start + step]]
                for f in futures:
                    out.append(f.result())
                    if done is not None:
                        done()
                if stop is not None and len(out) < len(args) and stop(out):
                    break
        return out
    finally:
        for k in share or {}:
            _SHARED.pop(k, None)

