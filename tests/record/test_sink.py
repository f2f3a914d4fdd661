"""The recording's file: clear errors where it cannot be created or written."""
from __future__ import annotations

import errno
import os
import time
from pathlib import Path

import pytest

from fingertip.record import Recorder, RecorderError, Recording
from fingertip.errors import exit_code
from fingertip.record.sink import io_error


def test_unwritable_places_are_clear_errors(tmp_path):
    ro = tmp_path / "readonly"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        if os.access(ro, os.W_OK):  # root ignores the mode: use a filesystem that refuses
            target = "/sys/fingertip-test.mcap"
        else:
            target = str(ro / "x.mcap")
        with pytest.raises(RecorderError, match="cannot create .*(Permission denied|"
                                                "Read-only)") as e:
            Recorder(target).start()
    finally:
        ro.chmod(0o755)
    refused = [e.value]
    with pytest.raises(RecorderError, match="does not exist") as e:
        Recorder(tmp_path / "no" / "such" / "dir.mcap").start()
    refused.append(e.value)
    with pytest.raises(RecorderError, match="is a directory") as e:
        Recorder(tmp_path).start()
    refused.append(e.value)
    existing = tmp_path / "old.mcap"
    existing.write_bytes(b"keep me")
    with pytest.raises(RecorderError, match="already exists") as e:
        Recorder(existing).start()
    refused.append(e.value)
    assert [exit_code(x) for x in refused] == [2, 2, 2, 2]  # the path the user gave
    assert existing.read_bytes() == b"keep me"
    Recorder(existing, overwrite=True).start().close()
    assert Recording(existing).complete


@pytest.mark.realtime
def test_dev_full_fails_at_start():
    t0 = time.monotonic()
    with pytest.raises(RecorderError, match="No space left on device.*full"):
        Recorder("/dev/full").start()
    assert time.monotonic() - t0 < 1.0


def test_io_errors_say_why():
    p = Path("/data/run.mcap")
    assert str(io_error(p, OSError(errno.ENOSPC, "No space left on device"), "writing failed:")
               ) == ("writing failed: /data/run.mcap: No space left on device (the disk or "
                     "quota is full, or the file hit a size limit)")
    assert "(no permission to write there)" in str(
        io_error(p, OSError(errno.EACCES, "Permission denied"), "cannot create"))
    assert "(the folder /data does not exist)" in str(
        io_error(p, OSError(errno.ENOENT, "No such file"), "cannot create"))
    assert str(io_error(p, OSError(errno.EIO, "I/O error"), "x")) == "x /data/run.mcap: I/O error"


def test_io_errors_carry_the_exit_status_of_their_cause():
    p = Path("/data/run.mcap")
    full, denied = OSError(errno.ENOSPC, "No space left"), OSError(errno.EACCES, "Denied")
    assert exit_code(io_error(p, denied, "cannot create")) == 2  # the user's path
    assert exit_code(io_error(p, full, "cannot create")) == 1  # a full disk: a failure
    assert exit_code(io_error(p, denied, "writing failed:", code=1)) == 1  # after the start
