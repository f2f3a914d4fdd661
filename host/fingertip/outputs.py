"""One policy for every file a command reads or writes (record, repair, export, train,
calibrate, sim dataset, check --json, plots), so that nothing a user has is lost:

- an input or output that is a FIFO, a device or a socket is refused in one line before
  anything is opened (``open()`` on a FIFO blocks until a writer comes: for ever);
- an existing output is refused unless the command was given ``--force``, and a folder is
  never taken for a file output;
- an output is never one of the command's inputs;
- a file is written to a temporary file with a unique name in the target folder
  (:func:`tempfile.mkstemp`, never derived from the output's name alone, so it cannot be an
  input named like it) and renamed over the output only when the output is a regular file
  or does not exist (never over ``/dev/null`` or ``/dev/full``).

Refusals are :class:`~fingertip.errors.OutputRefused` (an output) or
:class:`~fingertip.errors.BadFileError` (an input, :func:`~fingertip.badfile.check_input`):
exit status 2. Imports only :mod:`fingertip.errors` and :mod:`fingertip.badfile`.
"""
from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from .badfile import special_kind, stat_or_none
from .errors import OutputRefused


class OutputExists(OutputRefused, FileExistsError):
    """The output exists and ``--force`` was not given (also a FileExistsError, which older
    callers catch)."""

PathLike = str | os.PathLike


def _same(a: Path, b: Path) -> bool:
    with contextlib.suppress(OSError):
        return a.samefile(b)
    return a.resolve() == b.resolve()


def check_output(path: PathLike, *, force: bool = False, inputs: Iterable[PathLike] = (),
                 what: str = "output", folder: bool = False) -> Path:
    """``path`` as a Path if a command may write it, else :class:`OutputRefused` naming why.

    ``folder``: the output is a folder (created if missing; an existing non-empty one needs
    ``force``). Otherwise a file: refused when it is a folder, a FIFO, a device or a socket,
    one of ``inputs``, or when it exists and ``force`` is false. Its folder must exist."""
    p = Path(path)
    if str(path) == "":
        raise OutputRefused(f"the {what} path is empty: give a file name")
    st = stat_or_none(p)
    for i in inputs:
        if st is not None and _same(p, Path(i)):
            raise OutputRefused(f"{p}: the {what} is also an input: give another name")
    if st is not None and (kind := special_kind(st.st_mode)) is not None:
        raise OutputRefused(f"{p}: is {kind}: the {what} must be a regular "
                            f"{'folder' if folder else 'file'}")
    if folder:
        if st is not None and not stat.S_ISDIR(st.st_mode):
            raise OutputRefused(f"{p}: exists and is not a folder (the {what} is a folder)")
        if st is not None and not force and any(p.iterdir()):
            raise OutputRefused(f"{p}: the folder is not empty (add --force to write into "
                                "it, or choose another folder)")
        return p
    if st is not None and stat.S_ISDIR(st.st_mode):
        raise OutputRefused(f"{p} is a directory: give a file name such as "
                            f"{p / ('run' + (p.suffix or '.mcap'))}")
    if st is not None and not force:
        raise OutputExists(f"{p} already exists (choose another name, or add --force to "
                           "replace it)")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise OutputRefused(f"{p}: its folder {parent} does not exist")
    return p


def temp_path(dest: PathLike) -> Path:
    """A new, empty file with a unique name beside ``dest`` (same folder, so a rename is
    atomic), made with :func:`tempfile.mkstemp`: it cannot be an existing file."""
    d = Path(dest)
    fd, name = tempfile.mkstemp(prefix=f".{d.name[:40]}.", suffix=".part",
                                dir=d.parent if str(d.parent) else ".")
    try:
        os.fchmod(fd, 0o666 & ~_umask())  # mkstemp's 0600 would outlive the rename
    finally:
        os.close(fd)
    return Path(name)


def _umask() -> int:
    """The process's umask (Linux reports it without changing it)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    return 0o022


def replace(tmp: PathLike, dest: PathLike) -> None:
    """Rename ``tmp`` over ``dest`` if ``dest`` is a regular file or missing; otherwise
    remove ``tmp`` and refuse (a device node or a FIFO is never replaced)."""
    d = Path(dest)
    st = stat_or_none(d)
    if st is not None and not stat.S_ISREG(st.st_mode):
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise OutputRefused(f"{d}: is not a regular file: not replaced")
    os.replace(tmp, d)


@contextlib.contextmanager
def atomic_output(dest: PathLike) -> Iterator[Path]:
    """``with atomic_output(out) as tmp:`` write ``tmp``; on success it replaces ``out``
    (:func:`replace`), on an exception it is removed and ``out`` is untouched."""
    tmp = temp_path(dest)
    try:
        yield tmp
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    replace(tmp, dest)


def writable_folder(path: PathLike) -> Path:
    """Create the folder ``path`` (and its parents) and check that a file can be made in it,
    before a command writes anything there; an :class:`OSError` says why not. The check's
    file has a unique name (:func:`tempfile.mkstemp`), so no file of the user's is touched."""
    folder = Path(path)
    folder.mkdir(parents=True, exist_ok=True)
    fd, probe = tempfile.mkstemp(dir=folder, prefix=".fingertip-", suffix=".probe")
    os.close(fd)
    os.unlink(probe)
    return folder


def write_text(dest: PathLike, text: str) -> Path:
    """``text`` (UTF-8) written to ``dest`` through :func:`atomic_output`: a reader, or a
    crash, never leaves half a file."""
    with atomic_output(dest) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(dest)
