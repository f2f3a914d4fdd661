"""`fingertip calibrate record` from the command line: offline CSVs, the virtual rig over a
real pty and UDP, and bad input (exit 2, one line, nothing fitted)."""
from __future__ import annotations

import csv
import json
import subprocess
import sys

import pytest

from fingertip.sim.device.reference_rig import simulate_reference_run


def run_cli(*args, cwd, timeout=180):
    return subprocess.run([sys.executable, "-m", "fingertip.cli", "calibrate", "record", *args],
                          cwd=cwd, capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def csvs(tmp_path_factory):
    d = tmp_path_factory.mktemp("csv")
    r = simulate_reference_run(2, 60.0)
    with (d / "ft.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["host_time", "ch0", "ch1", "ch2", "ch3", "timeout_mask", "saturation_mask"])
        for t, c in zip(r.t_ft, r.counts, strict=True):
            w.writerow([f"{t + 1000:.6f}", *[int(v) for v in c], 0, 0])
    with (d / "ref.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["time", "fx", "fy", "fz"])
        for t, f in zip(r.t_ref, r.f_ref, strict=True):
            w.writerow([f"{t + 1000:.6f}", *[f"{v:.5f}" for v in f]])
    return d


def test_offline_csv_join_and_fit(csvs, tmp_path):
    r = run_cli("--fingertip-csv", str(csvs / "ft.csv"), "--reference-csv",
                str(csvs / "ref.csv"), "--models", "affine", "-o", "cal", "-q", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "clock offset: reference = fingertip +" in r.stdout
    al = json.loads((tmp_path / "cal" / "alignment.json").read_text())
    # 37 ms; generous (the benchmark reports the error over longer runs).
    assert al["offset_ms"] == pytest.approx(37, abs=max(10, 3 * al["uncertainty_ms"]))
    assert (tmp_path / "cal" / "force.onnx").is_file()


@pytest.mark.parametrize("edit,match", [
    (lambda rows: [["when", "fx", "fy"]] + rows[1:], "no column for time"),
    (lambda rows: rows[:1] + rows[1:][::-1], "times must increase"),
])
def test_bad_reference_csv(csvs, tmp_path, edit, match):
    rows = list(csv.reader((csvs / "ref.csv").open()))
    with (tmp_path / "bad.csv").open("w", newline="") as fh:
        csv.writer(fh).writerows(edit(rows))
    r = run_cli("--fingertip-csv", str(csvs / "ft.csv"), "--reference-csv",
                str(tmp_path / "bad.csv"), "-o", "cal", cwd=tmp_path)
    assert r.returncode == 2 and match in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "cal").exists()


def test_clocks_that_cannot_be_aligned(csvs, tmp_path):
    rows = list(csv.reader((csvs / "ref.csv").open()))
    with (tmp_path / "far.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(rows[0])
        for row in rows[1:]:
            w.writerow([f"{float(row[0]) + 3600:.6f}", *row[1:]])
    r = run_cli("--fingertip-csv", str(csvs / "ft.csv"), "--reference-csv",
                str(tmp_path / "far.csv"), "-o", "cal", cwd=tmp_path)
    assert r.returncode == 2 and "cannot be aligned" not in r.stdout
    assert "overlap" in r.stderr and not (tmp_path / "cal").exists()


def test_no_reference_packets(tmp_path):
    r = run_cli("--virtual", "--rdt", "127.0.0.1:9", "--duration", "5", cwd=tmp_path)
    assert r.returncode == 2 and "no RDT packets" in r.stderr


@pytest.mark.parametrize("args,match", [
    ((), "give the fingertip: --port, --serial or --virtual"),
    (("--models", "poly0"), "bad polynomial 'poly0'"),
])
def test_one_line_for_a_missing_fingertip_or_an_unknown_model(tmp_path, args, match):
    r = run_cli(*args, cwd=tmp_path)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert match in r.stderr.strip().splitlines()[-1]  # one line (after argparse's usage)


@pytest.mark.realtime
def test_virtual_rig_end_to_end(tmp_path):
    """Real pty, real UDP: the simulated Net F/T lags 37 ms and loses 1 % of its packets."""
    r = run_cli("--virtual", "--duration", "20", "--models", "affine", "-o", "cal", "-q",
                cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    al = json.loads((tmp_path / "cal" / "alignment.json").read_text())
    # The host-side stamps add the bridge's own mapping error: a generous bound.
    assert al["offset_ms"] == pytest.approx(37, abs=10)
    assert (tmp_path / "cal" / "calibration_report.png").is_file()
