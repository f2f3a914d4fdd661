"""Files a user hands us that cannot be used: one exception type, one line, exit status 2.

Every command that loads a model (.onnx), a recording (.mcap, WAV...), a dataset or a
configuration reports a bad file the same way: ``ERROR fingertip: <file>: <why>`` and exit
status 2, never a traceback. Loaders raise :class:`~fingertip.errors.BadFileError` (defined
with the rest of the package's vocabulary in :mod:`fingertip.errors`; a ``ValueError``, so
older ``except ValueError`` code still catches it); command handlers are wrapped in
:func:`reports_bad_files`, which turns it, and the operating system's refusals (no such
file, a folder, no permission), into that one line.

Imports only :mod:`fingertip.errors` (rank 0), so every layer may use it.
"""
from __future__ import annotations

import functools
import logging
import os
import stat
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .errors import BadFileError, one_line

log = logging.getLogger("fingertip")

__all__ = ["BadFileError", "FILE_ERRORS", "describe", "one_line", "reports_bad_files",
           "require_file", "check_input", "special_kind",
           "stat_or_none"]


def require_file(path: str | os.PathLike, what: str) -> Path:
    """``path`` as a Path if it is a non-empty regular file; otherwise a BadFileError that
    says which of missing / a folder / a FIFO, device or socket / empty it is (``what``:
    "ONNX model", "recording"...)."""
    p = Path(path)
    if not p.exists():
        raise BadFileError(f"{p}: no such file (expected {what})", p)
    if p.is_dir():
        raise BadFileError(f"{p}: is a folder, not {_article(what)} {what}", p)
    check_input(p, what)  # a FIFO, a device or a socket: refused before open() blocks
    try:
        size = p.stat().st_size
    except OSError as e:
        raise BadFileError(f"{p}: cannot read ({e.strerror or e})", p) from e
    if size == 0:
        raise BadFileError(f"{p}: the file is empty (expected {what})", p)
    return p


def special_kind(mode: int) -> str | None:
    """What a file of ``mode`` is when it is not a regular file or a folder (a FIFO, a
    device, a socket), else None."""
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return None


def stat_or_none(path: Path) -> os.stat_result | None:
    """``path``'s stat, or None when it cannot be had."""
    try:
        return path.stat()
    except OSError:
        return None  # missing, a broken link, no permission on a parent: open() says


def check_input(path: str | os.PathLike, what: str = "file") -> Path:
    """``path`` unless it is a FIFO, a device or a socket (refused before it is opened:
    reading one may block for ever). A missing file is left for the opener to name."""
    p = Path(path)
    st = stat_or_none(p)
    if st is not None and (kind := special_kind(st.st_mode)) is not None:
        raise BadFileError(f"{p}: is {kind}, not a regular file (expected {what})", p)
    return p


def _article(word: str) -> str:
    return "an" if word[:1].lower() in "aeiou" else "a"


FILE_ERRORS: tuple[type[BaseException], ...] = (BadFileError, FileNotFoundError,
                                                IsADirectoryError, NotADirectoryError,
                                                PermissionError, UnicodeDecodeError)
"""What a user's file can cause anywhere below a command: reported as one line, exit 2."""


def describe(e: BaseException) -> str:
    """One line for an exception of :data:`FILE_ERRORS`."""
    if isinstance(e, OSError) and e.filename is not None:
        return one_line(f"{e.filename}: {e.strerror or e}")
    if isinstance(e, UnicodeDecodeError):
        return one_line(f"not a text file ({e.reason} at byte {e.start})")
    return one_line(str(e))


def reports_bad_files(fn: Callable[[Any], int]) -> Callable[[Any], int]:
    """Wrap a command handler (``args -> exit code``): a bad file ends it with one log line
    and exit status 2."""
    @functools.wraps(fn)
    def run(args: Any) -> int:
        try:
            return fn(args)
        except FILE_ERRORS as e:
            log.error("%s", describe(e))
            return 2
    return run
