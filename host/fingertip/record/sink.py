"""The file a recording goes to: created with the checks a user needs (no folder, no silent
overwrite), and written without a buffer so that every record reaches the OS at once (and,
with ``fsync``, the disk at every flush)."""
from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

from ..errors import EXIT_USAGE, exit_code
from .stats import RecorderError


class Sink:
    """Unbuffered file for the MCAP writer: every record it writes reaches the OS at once."""

    def __init__(self, fd: int, fsync: bool) -> None:
        self.fd = fd
        self.pos = 0
        self.fsync = fsync

    def write(self, data: bytes | bytearray | memoryview) -> int:
        view = memoryview(data)
        total = len(view)
        while view:
            n = os.write(self.fd, view)
            if n <= 0:  # pragma: no cover - os.write raises rather than return 0 on files
                raise OSError(errno.EIO, "write returned 0")
            view = view[n:]
            self.pos += n
        return total

    def tell(self) -> int:
        return self.pos

    def flush(self) -> None:
        if self.fsync:
            try:
                os.fsync(self.fd)
            except OSError as e:
                if e.errno not in (errno.EINVAL, errno.EROFS):  # not a regular file
                    raise

    def close(self) -> None:
        os.close(self.fd)


def open_output(p: Path, overwrite: bool) -> tuple[int, bool]:
    """Open ``p`` for writing: ``(fd, created)``; a folder, an existing file (unless
    ``overwrite``) or an OS refusal is a :class:`RecorderError` that says why."""
    try:
        st = p.stat()
    except FileNotFoundError:
        st = None
    except OSError as e:
        raise io_error(p, e, "cannot record to") from e
    if st is not None and stat.S_ISDIR(st.st_mode):
        raise RecorderError(f"cannot record to {p}: it is a directory; give a file name "
                            "such as run.mcap", exit_code=EXIT_USAGE)
    regular = st is None or stat.S_ISREG(st.st_mode)
    if st is not None and regular and not overwrite:
        raise RecorderError(f"{p} already exists (choose another name, or overwrite it "
                            "explicitly)", exit_code=EXIT_USAGE)
    flags = os.O_WRONLY | os.O_CREAT | getattr(os, "O_CLOEXEC", 0)
    if regular:
        flags |= os.O_TRUNC
    if st is None and not overwrite:
        flags |= os.O_EXCL  # it must not appear between the check and the open
    try:
        return os.open(p, flags, 0o644), st is None
    except FileExistsError as e:
        raise RecorderError(f"{p} already exists (choose another name, or overwrite it "
                            "explicitly)", exit_code=EXIT_USAGE) from e
    except OSError as e:
        raise io_error(p, e, "cannot create") from e


def io_error(path: Path, e: OSError, what: str, code: int | None = None) -> RecorderError:
    """``e`` as one line that says what failed on ``path`` and, when it can, why."""
    reason = e.strerror or str(e)
    hint = ""
    if e.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
        hint = " (the disk or quota is full, or the file hit a size limit)"
    elif e.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        hint = " (no permission to write there)"
    elif e.errno == errno.ENOENT:
        hint = f" (the folder {path.parent} does not exist)"
    # ``code`` None: the OS's refusal of a path the user gave is theirs (2), a full disk a
    # failure (1)
    return RecorderError(f"{what} {path}: {reason}{hint}",
                         exit_code=exit_code(e) if code is None else code)
