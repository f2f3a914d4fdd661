"""Run one bad-input case and judge it: the exit status, exactly one error line naming the
problem, no traceback, nothing damaged (every workspace file hashed before and after, the
device nodes still devices), no hang.

Command-line cases run ``fingertip.cli.main`` in-process (in a worker thread, so a hang is
a timeout, not a stuck suite); signal cases run the real ``python -m fingertip.cli`` with
the child's SIGINT handler reset to the default (a suite started as a background job of a
script has SIGINT ignored, and children inherit that). API cases call the library and expect
an exception of the package's vocabulary with its rule in the message.
"""
from __future__ import annotations

import contextlib
import hashlib
import io
import logging
import os
import shlex
import signal
import stat
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from tests.children import default_signals

from .cases import Case
from .workspace import Workspace

DEVICE_NODES = ("/dev/null", "/dev/full", "/dev/zero")


@dataclass
class Outcome:
    case: str
    code: int | None
    lines: list[str]
    traceback: bool
    damaged: list[str]
    hung: bool
    problems: list[str]

    @property
    def handled(self) -> bool:
        return not self.problems


def snapshot(root: Path) -> dict[str, str]:
    """sha1 of every regular file under ``root`` (FIFOs and ptys skipped), and the kind of
    the device nodes a case could replace."""
    out: dict[str, str] = {}
    for dirpath, _, files in os.walk(root):
        for f in files:
            p = Path(dirpath) / f
            try:
                st = p.lstat()
            except OSError:
                continue
            if stat.S_ISREG(st.st_mode):
                out[str(p)] = hashlib.sha1(p.read_bytes()).hexdigest()
    for node in DEVICE_NODES:
        with contextlib.suppress(OSError):
            out[node] = "char" if stat.S_ISCHR(os.stat(node).st_mode) else "REPLACED"
    return out


class _Lines(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)


def _unblock(ws: Workspace) -> None:
    """Open the FIFO both ways without blocking: any open() stuck on it returns."""
    with contextlib.suppress(OSError):
        fd = os.open(ws["fifo"], os.O_RDWR | os.O_NONBLOCK)
        time.sleep(0.2)
        os.close(fd)


def run_cli(argv: list[str], ws: Workspace, timeout: float) -> tuple[int | None, str, list,
                                                                     bool]:
    """(exit status or None when it hung, stderr text, log records, hung)."""
    from fingertip.cli import main

    handler = _Lines()
    logger = logging.getLogger("fingertip")
    logger.addHandler(handler)
    err, out = io.StringIO(), io.StringIO()
    result: dict[str, object] = {}

    def target() -> None:
        try:
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
                result["code"] = main(argv)
        except SystemExit as e:  # argparse
            result["code"] = e.code if isinstance(e.code, int) else 2
        except BaseException as e:  # noqa: BLE001 - escaped: a defect the case reports
            result["escaped"] = e

    t = threading.Thread(target=target, daemon=True)
    t.start()
    t.join(timeout)
    hung = t.is_alive()
    if hung:
        _unblock(ws)
        t.join(5)
    logger.removeHandler(handler)
    text = err.getvalue()
    if "escaped" in result:
        e = result["escaped"]
        text += f"\nTraceback (escaped): {type(e).__name__}: {e}"
        result["code"] = 1
    return result.get("code"), text, handler.records, hung  # type: ignore[return-value]


def _child_ignore_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def run_proc(case: Case, argv: list[str], timeout: float) -> tuple[int | None, str, bool]:
    """The real command in a child; ``case.signal`` sent after ``case.after`` seconds (or
    after the line ``case.wait_for`` appeared on stderr)."""
    env = dict(os.environ)
    root = Path(__file__).resolve().parents[2]
    env["PYTHONPATH"] = os.pathsep.join([str(root / "host"), env.get("PYTHONPATH", "")])
    pre = _child_ignore_sigint if case.sigint_ignored else default_signals
    on_stdout = case.wait_on == "stdout"
    proc = subprocess.Popen([sys.executable, "-m", "fingertip.cli", *argv],
                            stdout=subprocess.PIPE if on_stdout else subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, env=env, preexec_fn=pre)
    stream = proc.stdout if on_stdout else proc.stderr
    try:
        if case.wait_for == HANDLERS:
            _wait_handlers(proc.pid, timeout)
        elif case.wait_for:
            deadline = time.monotonic() + timeout
            line = ""
            while case.wait_for not in line and time.monotonic() < deadline:
                line = stream.readline()
                if not line and proc.poll() is not None:
                    break
        time.sleep(case.after)
        if case.signal:
            proc.send_signal(getattr(signal, case.signal))
        _, err = proc.communicate(timeout=timeout)
        return proc.returncode, err, False
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
        return None, err, True


HANDLERS = "handlers"
"""``wait_for`` value: wait until the child catches SIGINT, SIGTERM and SIGHUP (its own
code runs: before that, Python's start-up answers a signal, not ours)."""


def _wait_handlers(pid: int, timeout: float) -> None:
    want = (1 << (signal.SIGINT - 1)) | (1 << (signal.SIGTERM - 1)) | (1 << (signal.SIGHUP - 1))
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            status = Path(f"/proc/{pid}/status").read_text()
        except OSError:
            return  # ended
        caught = int(next(ln.split()[1] for ln in status.splitlines()
                          if ln.startswith("SigCgt:")), 16)
        if caught & want == want:
            return
        time.sleep(0.005)


def error_lines(text: str, records: list) -> list[str]:
    """The error lines a user saw: ERROR log records, argparse's ``error:`` line, and ERROR
    lines of a child's stderr."""
    lines = [r.getMessage() for r in records if r.levelno >= logging.ERROR]
    for ln in text.splitlines():
        if ": error: " in ln or (ln.startswith("ERROR ") and not records):
            lines.append(ln)
    return lines


def judge(case: Case, ws: Workspace, tmp: Path) -> Outcome:
    """Run ``case`` with ``{tmp}`` a fresh folder and judge what it did."""
    ws.paths["tmp"] = tmp
    before = snapshot(ws.root)
    problems: list[str] = []
    records: list = []
    if case.api is not None:
        code, text, hung = _run_api(case, ws)
    else:
        argv = [ws.fmt(a) for a in shlex.split(case.argv)]
        if case.proc:
            code, text, hung = run_proc(case, argv, case.timeout)
        else:
            code, text, records, hung = run_cli(argv, ws, case.timeout)
    after = snapshot(ws.root)
    damaged = sorted(k for k, v in before.items() if after.get(k) != v)
    lines = error_lines(text, records) if case.api is None else (
        [text] if text else [])
    tb = "Traceback" in text or any(r.exc_info for r in records)
    if hung:
        problems.append(f"hung for {case.timeout:g} s")
    elif case.code is not None and code not in (
            case.code if isinstance(case.code, tuple) else (case.code,)):
        problems.append(f"exit status {code}, expected {case.code}")
    if tb:
        problems.append("traceback: " + text[-300:])
    want_error = case.api is not None or (case.code not in (0, None)
                                          and not isinstance(case.code, tuple))
    if want_error and len(lines) != 1:
        problems.append(f"{len(lines)} error lines, expected 1: {lines[:3]}")
    if case.says:
        hay = " ".join(lines) if want_error else text + " ".join(
            r.getMessage() for r in records)
        if case.says.lower() not in hay.lower():
            problems.append(f"the error does not say {case.says!r}: {lines[:2] or text[-200:]}")
    if damaged:
        problems.append(f"damaged: {damaged}")
    if case.check is not None and not hung:
        why = case.check(ws)
        if why:
            problems.append(why)
    return Outcome(case.id, code, lines, tb, damaged, hung, problems)


def _run_api(case: Case, ws: Workspace) -> tuple[int | None, str, bool]:
    """Call ``case.api(ws)``: it must raise ``case.raises`` (the package's vocabulary) whose
    message holds ``case.says``; the 'exit status' is what the command line would map it
    to."""
    from fingertip.errors import exit_code

    result: dict[str, object] = {}

    def target() -> None:
        try:
            case.api(ws)
        except BaseException as e:  # noqa: BLE001 - judged below
            result["e"] = e

    t = threading.Thread(target=target, daemon=True)
    t.start()
    t.join(case.timeout)
    if t.is_alive():
        _unblock(ws)
        return None, "", True
    e = result.get("e")
    if e is None:
        return 0, "", False
    if case.raises is not None and not isinstance(e, case.raises):
        return exit_code(e), f"Traceback (wrong type): {type(e).__name__}: {e}", False
    return exit_code(e), str(e), False
