"""The error vocabulary, the exit-status mapping, the output policy, the input sanity check and
the stop signals (issue 28), tested directly."""
from __future__ import annotations

import ast
import errno
import os
import signal
import stat
from pathlib import Path

import numpy as np
import pytest

from fingertip.audio.sanity import signal_problem
from fingertip.badfile import BadFileError, check_input
from fingertip.cli.stopping import Interrupted, failed, run_command, stop_signals
from fingertip.errors import (
    BadArgumentError,
    BadArgumentTypeError,
    DeviceError,
    Error,
    ModelError,
    NetworkError,
    OutputRefused,
    describe,
    exit_code,
)
from fingertip.outputs import (
    OutputExists,
    atomic_output,
    check_output,
    replace,
    temp_path,
    writable_folder,
)


@pytest.mark.parametrize(("e", "code"), [
    (BadFileError("x.wav: empty"), 2),
    (BadArgumentError("tare samples must be in 0..256, not 9999"), 2),
    (BadArgumentTypeError("tare channels ..."), 2),
    (OutputRefused("fifo: is a FIFO"), 2),
    (DeviceError("lost"), 1),
    (DeviceError("no such port", exit_code=2), 2),
    (NetworkError("DDS failed"), 1),
    (ModelError("diverged"), 1),
    (KeyboardInterrupt(), 130),
    (Interrupted("SIGTERM"), 130),
    (FileNotFoundError(errno.ENOENT, "No such file", "a.mcap"), 2),
    (OSError(errno.ENOSPC, "No space left on device"), 1),
    (OSError(errno.EROFS, "Read-only file system"), 2),
    (KeyError("unknown"), 1),
    (RuntimeError("boom"), 1),
])
def test_every_exception_has_one_exit_status(e, code):
    assert exit_code(e) == code


def test_the_old_classes_are_of_the_vocabulary():
    from fingertip.device import FingertipError
    from fingertip.models.force.calibration.errors import CalibrationError
    from fingertip.protocol import ProtocolVersionError
    from fingertip.record.reader import RecordingError
    from fingertip.reference import ReferenceError
    from fingertip.transport import DeviceNotFound, TransportError

    assert issubclass(FingertipError, DeviceError) and issubclass(FingertipError, RuntimeError)
    assert issubclass(TransportError, DeviceError) and issubclass(TransportError, OSError)
    assert issubclass(DeviceNotFound, LookupError) and exit_code(DeviceNotFound("x")) == 2
    assert issubclass(ReferenceError, NetworkError) and issubclass(ReferenceError, ValueError)
    assert issubclass(RecordingError, Error) and exit_code(RecordingError("x")) == 2
    assert issubclass(CalibrationError, ValueError) and exit_code(CalibrationError("x")) == 2
    assert issubclass(ProtocolVersionError, DeviceError) and issubclass(ProtocolVersionError,
                                                                       RuntimeError)
    assert exit_code(ProtocolVersionError("v2")) == 2


def _exit_statuses_chosen_by_handlers() -> list[str]:
    """``file:function`` of every place in fingertip/cli that ends a command with an error
    status of its own choosing: a literal ``return 2`` (the user's input), or a literal
    non-zero ``return`` inside an ``except`` clause. ``dispatch`` printing the help when no
    command was named is argparse's usage status, not an error's."""
    import fingertip.cli

    found = []
    for path in sorted(Path(fingertip.cli.__file__).parent.glob("*.py")):
        tree = ast.parse(path.read_text())
        for fn in ast.walk(tree):
            if not isinstance(fn, ast.FunctionDef) or fn.name == "dispatch":
                continue
            in_except = {id(n) for h in ast.walk(fn) if isinstance(h, ast.ExceptHandler)
                         for n in ast.walk(h)}
            for node in ast.walk(fn):
                if (isinstance(node, ast.Return) and isinstance(node.value, ast.Constant)
                        and node.value.value not in (0, None)
                        and (node.value.value == 2 or id(node) in in_except)):
                    found.append(f"{path.name}:{fn.name}")
    return found


def test_command_handlers_leave_errors_to_the_one_mapping():
    """Issue 28: handlers raise the package's errors and stopping.run_command alone turns
    them into a line and an exit status; what stays is a result, not an error (``check``
    finding a fault, a recording that failed part-way keeping what it had: they log and
    return 1 outside any ``except``, after their summary)."""
    assert _exit_statuses_chosen_by_handlers() == [
        # a missing mujoco extra, no display for the viewer: to be raised by sim/mujoco
        "sim.py:_cmd_sim_mujoco", "sim.py:_cmd_sim_mujoco"]


def test_one_line_and_no_traceback_words():
    assert describe(BadArgumentError("a\n  b")) == "a b"
    assert describe(FileNotFoundError(errno.ENOENT, "No such file", "x.mcap")) == \
        "x.mcap: No such file"
    assert describe(KeyError("unknown")).startswith("internal error: KeyError: 'unknown'")
    bug = describe(AttributeError("'NoneType' object has no attribute 'x'"))
    assert bug.startswith("internal error: AttributeError") and "-v" in bug
    assert describe(Interrupted("SIGHUP")).startswith("interrupted")


def test_run_command_maps_and_logs_one_line(caplog):
    def fails(_):
        raise BadArgumentError("decimation must be in 1..255, not 0")

    assert run_command(fails, None) == 2
    errors = [r for r in caplog.records if r.levelname == "ERROR"]
    assert len(errors) == 1 and "1..255" in errors[0].getMessage() and not errors[0].exc_info
    caplog.clear()
    assert run_command(fails, None, verbose=1) == 2
    assert caplog.records[-1].exc_info  # -v shows where


@pytest.mark.parametrize("signame", ["SIGINT", "SIGTERM", "SIGHUP"])
def test_stop_signals_raise_once_then_restore(signame):
    sig = getattr(signal, signame)
    before = signal.getsignal(sig)
    with pytest.raises(Interrupted) as info, stop_signals():
        os.kill(os.getpid(), sig)
        for _ in range(100):  # the handler runs between bytecodes
            pass
    assert info.value.signame == signame
    assert signal.getsignal(sig) == before


def test_stop_signals_even_when_the_parent_ignored_sigint():
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)  # a background job of a script
    try:
        with pytest.raises(KeyboardInterrupt), stop_signals():
            os.kill(os.getpid(), signal.SIGINT)
            for _ in range(100):
                pass
        assert signal.getsignal(signal.SIGINT) == signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, old)


def test_an_interrupt_a_library_swallowed_is_still_an_interrupt(caplog):
    # As numpy's import did at a SIGHUP beside busy loops: the signal's exception vanished
    # inside its C extension and an unchained ImportError came out instead.
    with stop_signals():
        try:
            os.kill(os.getpid(), signal.SIGHUP)
            for _ in range(100):
                pass
        except Interrupted:
            pass
        code = failed(ImportError("IMPORTANT: PLEASE READ THIS FOR ADVICE"))
    assert code == 130
    assert "interrupted by SIGHUP" in caplog.text and "IMPORTANT" in caplog.text
    caplog.clear()
    with stop_signals():  # no signal this time: an error as any other
        assert failed(ImportError("no module named x")) == 1
    assert "interrupted" not in caplog.text


def test_special_files_are_refused_before_open(tmp_path):
    fifo = tmp_path / "f"
    os.mkfifo(fifo)
    with pytest.raises(BadFileError, match="FIFO"):
        check_input(fifo)
    with pytest.raises(BadFileError, match="device"):
        check_input("/dev/null")
    check_input(tmp_path / "missing")  # left for open() to name
    for path in (fifo, "/dev/full"):
        with pytest.raises(OutputRefused, match="FIFO|device"):
            check_output(path, force=True)


def test_outputs_exist_inputs_folders(tmp_path):
    f = tmp_path / "a.mcap"
    f.write_bytes(b"keep")
    with pytest.raises(OutputExists, match="already exists.*--force"):
        check_output(f)
    with pytest.raises(FileExistsError):
        check_output(f)
    assert check_output(f, force=True) == f
    with pytest.raises(OutputRefused, match="also an input"):
        check_output(f, force=True, inputs=[f])
    with pytest.raises(OutputRefused, match="is a directory"):
        check_output(tmp_path)
    with pytest.raises(OutputRefused, match="does not exist"):
        check_output(tmp_path / "no" / "x.mcap")
    with pytest.raises(OutputRefused, match="not a folder"):
        check_output(f, folder=True, force=True)
    with pytest.raises(OutputRefused, match="not empty"):
        check_output(tmp_path, folder=True)
    assert check_output(tmp_path, folder=True, force=True) == tmp_path
    assert f.read_bytes() == b"keep"


def test_temporary_files_are_unique_and_renamed_only_over_regular_files(tmp_path):
    out = tmp_path / "run.mcap"
    part = tmp_path / ".run.mcap.part"  # an input named as the old scheme named its temp
    part.write_bytes(b"input")
    a, b = temp_path(out), temp_path(out)
    assert a != b and part not in (a, b) and a.parent == tmp_path
    assert stat.S_IMODE(a.stat().st_mode) & 0o044  # not mkstemp's 0600 once renamed
    with atomic_output(out) as tmp:
        tmp.write_bytes(b"new")
    assert out.read_bytes() == b"new" and part.read_bytes() == b"input"
    with pytest.raises(RuntimeError), atomic_output(out) as tmp:
        tmp.write_bytes(b"half")
        raise RuntimeError("failed while writing")
    assert out.read_bytes() == b"new"
    with pytest.raises(OutputRefused, match="not a regular file"):
        replace(a, "/dev/null")
    assert not a.exists() and stat.S_ISCHR(os.stat("/dev/null").st_mode)
    b.unlink()
    assert sorted(p.name for p in tmp_path.iterdir()) == [".run.mcap.part", "run.mcap"]


def test_a_writable_folder_is_made_and_left_as_it_was(tmp_path):
    mine = tmp_path / "out" / ".fingertip-export-probe"  # the old fixed probe name
    mine.parent.mkdir()
    mine.write_bytes(b"the user's")
    assert writable_folder(tmp_path / "out") == tmp_path / "out"
    assert [p.name for p in mine.parent.iterdir()] == [mine.name]
    assert mine.read_bytes() == b"the user's"
    assert writable_folder(tmp_path / "a" / "b").is_dir()  # parents too
    with pytest.raises(OSError):
        writable_folder(mine / "x")  # under a file


@pytest.mark.parametrize(("x", "full_scale", "says"), [
    (np.zeros(1000), 1.0, "silent"),
    (np.zeros(1000, np.int16), None, "silent"),
    (np.full(1000, 0.25), 1.0, "constant"),
    (np.where(np.arange(1000) == 3, np.nan, 0.1), 1.0, "NaN"),
    (np.where(np.arange(1000) == 3, np.inf, 0.1), 1.0, "infinite"),
    (np.clip(np.random.default_rng(0).normal(0, 3, 1000), -1, 1), 1.0, "clipped"),
    (np.array([], float), 1.0, "empty"),
    (np.array(["a", "b"]), None, "not numbers"),
])
def test_unusable_recordings_are_named(x, full_scale, says):
    assert says in signal_problem(x, full_scale)


def test_usable_recordings_pass():
    rng = np.random.default_rng(1)
    assert signal_problem(rng.normal(0, 0.1, 44100), 1.0) is None
    assert signal_problem((rng.normal(0, 3000, (4410, 2))).astype(np.int16)) is None
    sine = np.sin(np.linspace(0, 200 * np.pi, 8000))  # peaks at full scale, not clipped
    assert signal_problem(sine, 1.0) is None


@pytest.mark.parametrize("when", ["put in", "put back"])
def test_a_signal_as_the_handlers_are_put_in_or_back_is_an_interrupt(monkeypatch, caplog,
                                                                      when):
    # Beside busy loops, `record` got its SIGINT just as the last handler went in: Python
    # ran the handler on the next bytecode, still inside signal.signal, before the command's
    # own try, and the process ended with a traceback and status 1. Putting them back is
    # the same window: SIGHUP while SIGINT's old handler goes back, SIGHUP's still ours.
    from fingertip import cli
    from fingertip.cli import stopping

    real = signal.signal
    first, last = stopping.STOP_SIGNALS[0], stopping.STOP_SIGNALS[-1]
    sent = signal.SIGINT if when == "put in" else last
    fired = []

    def install(sig, handler):
        old = real(sig, handler)
        ours = handler is stopping._on_signal
        if not fired and ((when == "put in" and ours and sig == last)
                          or (when == "put back" and not ours and sig == first)):
            fired.append(sig)
            signal.raise_signal(sent)   # its handler runs on the next bytecode
        return old

    before = {s: signal.getsignal(s) for s in stopping.STOP_SIGNALS}
    monkeypatch.setattr(signal, "signal", install)
    assert cli.main(["--version"]) == 130
    assert fired and f"interrupted by {signal.Signals(sent).name}" in caplog.text
    assert {s: signal.getsignal(s) for s in stopping.STOP_SIGNALS} == before  # all back
