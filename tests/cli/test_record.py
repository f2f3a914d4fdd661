"""`fingertip record | replay | export`: parsers, handlers, exit codes, messages."""
from __future__ import annotations

import argparse
import json
import logging
import subprocess
import sys
import time

import numpy as np
import pytest
import soundfile as sf

from fingertip.record import Recording
from tests.children import default_signals
from fingertip.cli.record import add_parsers, main
from fingertip.cli.stopping import run_command

logging.getLogger("fingertip").setLevel(logging.INFO)


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="fingertip")
    add_parsers(p.add_subparsers(dest="command"))
    return p


def run(*argv: str) -> int:
    """The command's exit status, its errors mapped by the command line's one mapping."""
    args = parser().parse_args(argv)
    return run_command(args.func, args)


def errors(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.levelno >= logging.ERROR]


def test_parsers():
    p = parser()
    a = p.parse_args(["record", "--port", "/dev/x", "-o", "a.mcap", "--duration", "2",
                      "--audio-file", "x.wav", "--tare", "8", "--name", "thumb"])
    assert (a.port, a.output, a.duration, a.audio_file, a.tare, a.name, a.flush_interval) == \
        ("/dev/x", "a.mcap", 2.0, "x.wav", 8, "thumb", 0.5)
    a = p.parse_args(["replay", "r.mcap", "--as-fast-as-possible", "--json"])
    assert a.as_fast_as_possible and a.json and a.speed == 1.0
    assert p.parse_args(["export", "r.mcap", "-o", "d"]).output == "d"
    for bad in (["record", "-o", "a.mcap"],  # no device
                ["record", "--port", "p", "--serial", "s", "-o", "a"],
                ["record", "--port", "p"],  # no output
                ["record", "--port", "p", "-o", "a", "--audio", "1", "--audio-file", "w"],
                ["record", "--port", "p", "-o", "a", "--duration", "-1"],
                ["replay", "r.mcap", "--speed", "0"],
                ["replay", "r.mcap", "--speed", "2", "--as-fast-as-possible"],
                ["export", "r.mcap"]):
        with pytest.raises(SystemExit) as e:
            p.parse_args(bad)
        assert e.value.code == 2


def test_record_replay_export(device, tmp_path, capsys, caplog):
    wav = tmp_path / "piezo.wav"
    tone = (np.sin(np.arange(44100) * 0.05) * 8000).astype(np.int16)
    sf.write(wav, tone, 44100, subtype="PCM_16")
    out = tmp_path / "run.mcap"
    code = run("record", "--port", str(device.link), "-o", str(out), "--duration", "1.2",
               "--audio-file", str(wav), "--tare", "4", "--name", "thumb",
               "--force-model", "tests.record.models:linear")
    err = capsys.readouterr().err
    assert code == 0, errors(caplog)
    assert "recording thumb from" in err and "recorded 1.2 s to" in err
    assert "dropped 0" in err
    rec = Recording(out)
    assert rec.complete
    kinds = {}
    for r in rec.records():
        kinds.setdefault(r.kind, []).append(r.msg)
    assert len(kinds["raw"]) >= 80 and len(kinds["wrench"]) == len(kinds["raw"])
    assert [e.kind for e in kinds["events"]] == ["tare", "start", "stop"]
    offsets = json.loads(kinds["events"][0].detail)
    assert len(offsets) == 4 and 1000 <= offsets[0] < 1100 and kinds["events"][0].value == 4
    assert all(abs(m.counts[1]) < 100 for m in kinds["raw"])  # tared
    audio = np.concatenate([np.frombuffer(m.data, "<i2") for m in kinds["audio"]])
    assert len(audio) >= 44100 * 1.0
    np.testing.assert_array_equal(audio, tone[:len(audio)])

    code = run("replay", str(out), "--as-fast-as-possible", "--json")
    cap = capsys.readouterr()
    assert code == 0
    lines = [json.loads(x) for x in cap.out.splitlines()]
    assert len(lines) == len(kinds["raw"])
    assert set(lines[0]) == {"seq", "device_time_us", "host_time", "counts", "timeout_mask",
                             "saturation_mask"}
    assert [x["counts"] for x in lines] == [list(m.counts) for m in kinds["raw"]]
    assert f"{len(lines)} frames replayed" in cap.err

    assert run("replay", str(out), "--speed", "50", "--count", "5") == 0
    text = capsys.readouterr().out.splitlines()
    assert len(text) == 5 and text[0].split()[0] == str(kinds["raw"][0].seq)

    assert run("export", str(out), "-o", str(tmp_path / "csv")) == 0
    cap = capsys.readouterr()
    assert {p.split("/")[-1] for p in cap.out.split()} == {
        "thumb.csv", "thumb_audio.wav", "thumb_audio_chunks.csv", "events.csv"}
    assert "exported" in cap.err and f"thumb: {len(kinds['raw'])} frames" in cap.err


def test_user_errors_are_one_clear_line(device, tmp_path, capsys, caplog):
    port = str(device.link)
    cases = [
        (("record", "--port", str(tmp_path / "nope"), "-o", str(tmp_path / "a.mcap"),
          "--duration", "1"), "does not exist"),
        (("record", "--port", port, "-o", str(tmp_path / "no" / "dir" / "a.mcap"),
          "--duration", "1"), "does not exist"),
        (("record", "--port", port, "-o", str(tmp_path), "--duration", "1"),
         "is a directory"),
        (("record", "--port", port, "-o", "/dev/full", "--duration", "1"),
         "is a device"),
        (("record", "--port", port, "-o", str(tmp_path / "a.mcap"), "--name", "bad-name"),
         "cannot be part of a ROS 2 topic"),
        (("record", "--port", port, "-o", str(tmp_path / "a.mcap"), "--force-model",
          "tests.record.models:not_callable"), "not callable"),
        (("record", "--port", port, "-o", str(tmp_path / "a.mcap"), "--force-model",
          "no_such_module_xyz:f"), "cannot import"),
        (("record", "--port", port, "-o", str(tmp_path / "a.mcap"), "--force-model", "x"),
         "package.module:function"),
        (("record", "--port", port, "-o", str(tmp_path / "a.mcap"), "--audio-file",
          str(tmp_path / "none.wav")), "no such file"),
        (("replay", str(tmp_path / "none.mcap")), "no such file"),
        (("export", str(tmp_path / "none.mcap"), "-o", str(tmp_path / "o")), "no such file"),
    ]
    for argv, message in cases:
        caplog.clear()
        assert run(*argv) == 2, argv
        errs = errors(caplog)
        assert len(errs) == 1 and message in errs[0], (argv, errs)
    existing = tmp_path / "old.mcap"
    existing.write_bytes(b"data")
    caplog.clear()
    assert run("record", "--port", port, "-o", str(existing), "--duration", "0.3") == 2
    assert "already exists" in errors(caplog)[0] and "--force" in errors(caplog)[0]
    assert existing.read_bytes() == b"data"
    assert run("record", "--port", port, "-o", str(existing), "--duration", "0.3",
               "--force") == 0
    assert Recording(existing).complete
    capsys.readouterr()


@pytest.mark.realtime
def test_disk_filling_up_mid_recording_exits_1(device, tmp_path):
    """A file-size limit (RLIMIT_FSIZE, as a full quota would) hits while recording: one
    error line, exit code 1, promptly, and the file is readable up to the failure."""
    import resource
    import signal

    def limit():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (20_000, 20_000))

    out = tmp_path / "big.mcap"
    r = subprocess.run([sys.executable, "-m", "fingertip.cli", "record", "--port",
                        str(device.link), "-o", str(out), "--duration", "20",
                        "--flush-interval", "0.1", "--compression", "none"],
                       capture_output=True, text=True, timeout=30, preexec_fn=limit)
    assert r.returncode == 1, r.stderr
    err_lines = [x for x in r.stderr.splitlines() if x.startswith("ERROR")]
    assert len(err_lines) == 1 and "File too large" in err_lines[0]
    assert "recorded" in r.stderr
    elapsed = float(r.stderr.split("recorded ")[1].split(" s")[0])
    assert elapsed < 10
    rec = Recording(out)
    assert sum(1 for _ in rec.records(kinds=("raw",))) > 10


def test_module_entry_point(tmp_path, capsys):
    r = subprocess.run([sys.executable, "-m", "fingertip.cli", "--help"],
                       capture_output=True, text=True, timeout=30)
    assert r.returncode == 0 and "record" in r.stdout and "export" in r.stdout
    assert main([]) == 2
    capsys.readouterr()


@pytest.mark.parametrize("sig", ["SIGTERM", "SIGINT"])
def test_stop_signals_finish_the_file(device, tmp_path, sig):
    import signal

    out = tmp_path / "sig.mcap"
    proc = subprocess.Popen([sys.executable, "-m", "fingertip.cli", "record", "--port",
                             str(device.link), "-o", str(out)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            preexec_fn=default_signals)
    try:
        assert "recording" in proc.stderr.readline()
        time.sleep(0.8)
        proc.send_signal(getattr(signal, sig))
        _, err = proc.communicate(timeout=15)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err
    assert "recorded" in err
    rec = Recording(out)
    assert rec.complete and sum(1 for _ in rec.records(kinds=("raw",))) > 40


def test_progress_line_on_a_terminal(device, tmp_path):
    import os
    import pty

    master, slave = pty.openpty()
    out = tmp_path / "tty.mcap"
    proc = subprocess.Popen([sys.executable, "-m", "fingertip.cli", "record", "--port",
                             str(device.link), "-o", str(out), "--duration", "1.2"],
                            stdout=subprocess.DEVNULL, stderr=slave)
    os.close(slave)
    text = b""
    try:
        while True:
            try:
                chunk = os.read(master, 4096)
            except OSError:  # the child closed the terminal
                break
            if not chunk:
                break
            text += chunk
    finally:
        os.close(master)
        proc.wait(15)
    assert proc.returncode == 0
    progress = [x for x in text.decode().split("\r") if x.endswith("[connected]   ")]
    assert len(progress) >= 3 and all("dropped 0" in x for x in progress)
    # It counts up (how far it got in 1.2 s depends on how busy the machine is).
    counts = [int(x.split(" frames")[0].split()[-1]) for x in progress]
    assert counts == sorted(counts) and counts[-1] > counts[0] >= 0 and counts[-1] >= 10


def test_the_parsers_import_no_recording_machinery():
    """`fingertip --help` must stay fast: mcap, numpy & co. load only when a command runs."""
    r = subprocess.run([sys.executable, "-c", "import sys, fingertip.cli.record; "
                        "print(sorted(m for m in ('mcap', 'numpy', 'soundfile') "
                        "if m in sys.modules))"], capture_output=True, text=True, timeout=30)
    assert r.returncode == 0, r.stderr
    assert "mcap" not in r.stdout and "soundfile" not in r.stdout
    import fingertip.record as rec

    assert all(getattr(rec, n) is not None for n in rec.__all__)
    offered = {n for n in dir(rec) if not n.startswith("_")
               and getattr(getattr(rec, n), "__module__", "").startswith("fingertip.record.")}
    assert offered <= set(rec.__all__), "lazy names missing from __all__"
    assert {"Recorder", "Recording", "export", "Replay"} <= offered
    with pytest.raises(AttributeError):
        rec.nope  # noqa: B018
