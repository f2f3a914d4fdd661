"""The package's error vocabulary: one base class, one subclass per kind of cause, and the one
mapping from an exception to the line a user reads and the command's exit status.

    Error                      every error the package raises on purpose
    +-- BadFileError           a file given to us that cannot be used        exit 2
    +-- BadArgumentError       an argument outside its rule (ValueError)     exit 2
    |   +-- BadArgumentTypeError   ... of the wrong type (also TypeError)    exit 2
    |   +-- OutputRefused      an output path refused before anything opens  exit 2
    +-- DeviceError            the fingertip, its port or its firmware       exit 1 (or 2)
    +-- NetworkError           sockets, DDS, Zenoh, LSL, a reference sensor  exit 1 (or 2)
    +-- ModelError             training or running a model failed            exit 1 (or 2)

A message states the rule and the value that broke it ("tare samples must be in 1..256,
not 100000"). Each class carries the exit status it maps to (:attr:`Error.exit_code`; an
instance may override it: a device that does not answer on the port the user named is the
user's input, 2). Older exception classes of the package subclass these, so ``except
ValueError`` / ``except RuntimeError`` code keeps working.

:func:`exit_code` and :func:`describe` are the single mapping the command line uses
(``fingertip.cli.app.main``): 2 for the user's input, 1 for a failure at run time, 130 for
an interruption (Ctrl-C, SIGTERM, SIGHUP). No imports from the rest of the package, so every
layer may raise these.
"""
from __future__ import annotations

import errno
import os
import re
from pathlib import Path

MAX_LINE = 300
"""Characters of a reason kept: library messages can be long (a protobuf dump, a path list)."""

EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130


def one_line(text: object, limit: int = MAX_LINE) -> str:
    """``text`` with its line breaks and runs of spaces folded, cut to ``limit`` characters."""
    s = re.sub(r"\s+", " ", str(text)).strip()
    return s if len(s) <= limit else s[:limit - 3].rstrip() + "..."


class Error(Exception):
    """Base of every error the package raises on purpose. ``exit_code`` (class default,
    overridable per instance) is the command line's exit status for it."""

    exit_code: int = EXIT_FAILED

    def __init__(self, *args: object, exit_code: int | None = None) -> None:
        super().__init__(*args)
        if exit_code is not None:
            self.exit_code = exit_code

    def add_context(self, context: str) -> Error:
        """This error, its message led by ``context`` ("cannot calibrate from x.csv"): a
        caller that knows more than the raiser says it without changing the error's class
        or exit status. Returns ``self``, for ``raise e.add_context(...)``."""
        self.args = (f"{context}: {self}",)
        return self


class BadFileError(Error, ValueError):
    """A file that cannot be used for what it was given for. ``path`` names it (may be None
    when the message already does)."""

    exit_code = EXIT_USAGE

    def __init__(self, message: str, path: str | os.PathLike | None = None) -> None:
        super().__init__(one_line(message))
        self.path = None if path is None else Path(path)


class BadArgumentError(Error, ValueError):
    """An argument (a command-line option or a function's parameter) outside its rule; the
    message names the rule and the value."""

    exit_code = EXIT_USAGE


class BadArgumentTypeError(BadArgumentError, TypeError):
    """An argument of the wrong type (a string where channel numbers go...)."""


class OutputRefused(BadArgumentError):
    """An output path refused before anything was opened: it exists (without ``--force``),
    it is a folder, a FIFO, a device or a socket, or it is one of the inputs."""


class DeviceError(Error, RuntimeError):
    """The fingertip, its serial port or its firmware."""


class NetworkError(Error, RuntimeError):
    """Sockets, DDS, Zenoh, LSL or a networked reference sensor."""


class ModelError(Error, RuntimeError):
    """Training or running a model failed (a model *file* that cannot be used is a
    :class:`BadFileError`)."""


_USER_OS_ERRORS = (FileNotFoundError, IsADirectoryError, NotADirectoryError, PermissionError,
                   FileExistsError)
"""The operating system refusing a path the user gave: their input, exit 2."""

_USER_ERRNOS = {errno.ENOENT, errno.EISDIR, errno.ENOTDIR, errno.EACCES, errno.EPERM,
                errno.EEXIST, errno.ENAMETOOLONG, errno.EROFS, errno.ELOOP}


def exit_code(e: BaseException) -> int:
    """The exit status for ``e``: 130 interrupted, 2 the user's input, 1 anything else."""
    if isinstance(e, KeyboardInterrupt):
        return EXIT_INTERRUPTED
    code = getattr(e, "exit_code", None)  # Error, and classes that state theirs
    if isinstance(code, int) and not isinstance(code, bool):
        return code
    if isinstance(e, (*_USER_OS_ERRORS, UnicodeDecodeError)):
        return EXIT_USAGE
    if isinstance(e, OSError) and e.errno in _USER_ERRNOS:
        return EXIT_USAGE
    return EXIT_FAILED


def describe(e: BaseException) -> str:
    """One line for ``e`` that names the problem (never a traceback)."""
    if isinstance(e, KeyboardInterrupt):
        return "interrupted: stopped before the end"
    if isinstance(e, OSError) and not isinstance(e, Error):
        what = e.strerror or str(e) or type(e).__name__
        if e.filename is not None:
            return one_line(f"{e.filename}: {what}")
        return one_line(what)
    if isinstance(e, UnicodeDecodeError):
        return one_line(f"not a text file ({e.reason} at byte {e.start})")
    text = one_line(e)
    if isinstance(e, Error) or hasattr(e, "exit_code") or (
            isinstance(e, ValueError | LookupError) and not isinstance(e, KeyError | IndexError)
            and text):  # a KeyError's text is only the key: a defect of ours
        return text or type(e).__name__
    # Anything else is a defect of ours: say what it was, and how to see where.
    return one_line(f"internal error: {type(e).__name__}: {text or '(no message)'} "
                    "(please report it; `fingertip -v ...` shows where)")
