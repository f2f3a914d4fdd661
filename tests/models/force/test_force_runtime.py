"""ForceModel (onnxruntime only) and ``fingertip calibrate``: round trip, invalid inputs
flagged, frames with timeout/saturation masks, exit codes."""
from __future__ import annotations

import argparse
import json
import logging

import numpy as np
import pytest

from fingertip import Frame
from fingertip.cli.calibrate import add_parsers
from fingertip.cli.stopping import run_command
from fingertip.device import FingerFrame
from fingertip.models.force.calibrate import (
    INT24_MAX,
    INT24_MIN,
    fit_affine,
    fit_mlp,
    fit_poly,
    from_arrays,
    model_metadata,
)
from fingertip.models.force.runtime import ForceModel, ForceStatus, FrameForce, InvalidCounts
from fingertip.sim.physics import VirtualStrainSensor
from fingertip.sim.device.calibration_rig import calibration_sweep


@pytest.fixture(scope="module")
def data():
    s = VirtualStrainSensor(4)
    tare = np.rint(s.counts_batch(np.zeros((16, 2)), 0.0, np.arange(1, 17) / 80).mean(0))
    sw = calibration_sweep(s, seed=44, angles_deg=(-40, -20, 0, 20, 40), heights_mm=(1, 3))
    return from_arrays(sw.counts - tare, sw.fx, sw.fy, angle_deg=sw.angle_deg,
                       height_mm=sw.height_mm, trial=sw.trial)


@pytest.fixture(scope="module", params=["affine", "poly3", "mlp8"])
def model_file(request, data, tmp_path_factory):
    name = request.param
    d = data
    m = (fit_affine(d.counts, d.force) if name == "affine" else
         fit_poly(d.counts, d.force, 3) if name == "poly3" else
         fit_mlp(d.counts, d.force, (8,), epochs=1000))
    path = tmp_path_factory.mktemp("fm") / f"force_{name}.onnx"
    m.to_onnx(path, model_metadata(m, d, d, heldout={"heldout_rmse_n": 0.2}))
    return path, m


def test_round_trip(model_file, data):
    path, m = model_file
    fm = ForceModel(path)
    assert fm.channels == 4 and fm.units == "N" and fm.rmse_n == 0.2
    assert fm.kind == m.name and fm.metadata["fingertip_model"] == "force"
    assert fm.metadata["outputs"] == ["fx", "fy"] and fm.metadata["counts_gain"] == 128
    assert fm.train_rmse_n is not None and fm.train_rmse_n < 0.4
    ref = m.predict(data.counts)
    batch = fm.estimate(data.counts)
    assert batch.shape == (len(data), 2) and batch.dtype == np.float64
    np.testing.assert_allclose(batch, ref, atol=2e-4)
    one = fm.estimate(data.counts[5])
    assert one.shape == (2,)
    np.testing.assert_allclose(one, ref[5], atol=2e-4)
    fx, fy = fm(tuple(int(v) for v in data.counts[5]))      # callable, plain ints
    assert (fx, fy) == pytest.approx(tuple(one), abs=1e-6)
    f, st = fm.estimate(data.counts[:10], return_status=True)
    assert st.dtype == np.uint8 and not st.any()
    assert "ForceModel(" in repr(fm)


def test_estimate_xyz_is_estimate_as_floats(model_file, data):
    """The publisher's per-frame call gives exactly estimate()'s values (Python floats,
    z = 0), for valid frames, saturated ones (NaN) and the wrong channel count (error)."""
    fm = ForceModel(model_file[0])
    for row in data.counts[:20]:
        counts = tuple(int(v) for v in row)
        got = fm.estimate_xyz(counts)
        assert all(type(v) is float for v in got) and got[2] == 0.0
        assert got[:2] == tuple(fm.estimate(counts).tolist())
    sat = (8388607, 0, 0, 0)
    fx, fy, fz = fm.estimate_xyz(sat)
    assert np.isnan(fx) and np.isnan(fy) and fz == 0.0
    with pytest.raises(ValueError, match="4 channels"):
        fm.estimate_xyz((1, 2, 3))


def test_invalid_inputs_are_flagged(model_file, data):
    fm = ForceModel(model_file[0])
    x = np.repeat(data.counts[100:101], 6, axis=0)
    x[1, 0] = np.nan
    x[2, 3] = np.inf
    x[3, 1] = INT24_MAX
    x[4, 2] = INT24_MIN
    x[5, 0] = 4_000_000          # valid, far beyond the calibrated range
    f, st = fm.estimate(x, return_status=True)
    assert list(st) == [0, ForceStatus.NONFINITE, ForceStatus.NONFINITE, ForceStatus.SATURATED,
                        ForceStatus.SATURATED, ForceStatus.OUT_OF_RANGE]
    assert np.all(np.isfinite(f[[0, 5]])) and np.all(np.isnan(f[1:5]))
    one, s1 = fm.estimate(x[1], return_status=True)
    assert np.all(np.isnan(one)) and s1 == ForceStatus.NONFINITE and not s1.usable
    one, s5 = fm.estimate(x[5], return_status=True)
    assert np.all(np.isfinite(one)) and s5 == ForceStatus.OUT_OF_RANGE and s5.usable
    with pytest.raises(InvalidCounts, match="row 1, NONFINITE"):
        fm.estimate(x, strict=True)
    with pytest.raises(InvalidCounts, match="SATURATED") as e:
        fm.estimate(x[3], strict=True)
    assert e.value.status == ForceStatus.SATURATED
    # Masks, for counts that look fine.
    f, st = fm.estimate(x[:3], timeout_mask=[0, 0, 4], saturation_mask=[2, 0, 0],
                        return_status=True)
    assert list(st) == [ForceStatus.SATURATED, ForceStatus.NONFINITE,
                        ForceStatus.TIMEOUT | ForceStatus.NONFINITE]
    with pytest.raises(ValueError, match="takes 4 channels"):
        fm.estimate(np.zeros(3))
    with pytest.raises(ValueError, match="takes 4 channels"):
        fm.estimate(np.zeros((2, 5)))


def test_frames(model_file, data):
    fm = ForceModel(model_file[0])
    c = tuple(int(v) for v in data.counts[200])
    ref = fm.estimate(c)
    fr = Frame(seq=3, device_time_us=12_500, host_time=7.25, arrival_time=7.26, counts=c)
    r = fm.estimate_frame(fr)
    assert isinstance(r, FrameForce) and r.ok and r.status == ForceStatus.OK
    assert (r.fx, r.fy) == pytest.approx(tuple(ref), abs=1e-6)
    assert r.device_time_us == 12_500 and r.host_time == 7.25
    assert r.magnitude == pytest.approx(float(np.hypot(*ref)), abs=1e-6)
    bad = Frame(4, 25_000, 7.3, 7.31, c, timeout_mask=0b0010)
    r = fm.estimate_frame(bad)
    assert not r.ok and r.status == ForceStatus.TIMEOUT and np.isnan(r.fx)
    sat = Frame(5, 37_500, 7.4, 7.41, c, saturation_mask=0b1000)
    assert fm.estimate_frame(FingerFrame("thumb", sat)).status == ForceStatus.SATURATED
    with pytest.raises(InvalidCounts):
        fm.estimate_frame(sat, strict=True)
    # A 16-channel device: this fingertip on channels 4..7; masks of others do not matter.
    wide = Frame(6, 50_000, 7.5, 7.51, (0,) * 4 + c + (0,) * 8, timeout_mask=0b1,
                 saturation_mask=1 << 9)
    r = fm.estimate_frame(wide, channels=(4, 5, 6, 7))
    assert r.ok and (r.fx, r.fy) == pytest.approx(tuple(ref), abs=1e-6)
    wide_bad = Frame(7, 62_500, 7.6, 7.61, wide.counts, saturation_mask=1 << 6)
    f, st = fm.estimate_frames([wide, wide_bad], channels=(4, 5, 6, 7))
    assert list(st) == [0, ForceStatus.SATURATED] and np.isnan(f[1]).all()
    with pytest.raises(ValueError, match="need 4 channels"):
        fm.estimate_frame(wide, channels=(1, 2))


def test_gain_rescaling(model_file, data):
    fm128 = ForceModel(model_file[0])
    fm64 = ForceModel(model_file[0], gain=64)
    c = data.counts[150]
    np.testing.assert_allclose(fm64.estimate(c / 2), fm128.estimate(c), atol=1e-6)


def test_bad_files(tmp_path):
    with pytest.raises(FileNotFoundError):
        ForceModel(tmp_path / "none.onnx")
    (tmp_path / "junk.onnx").write_bytes(b"junk")
    with pytest.raises(ValueError, match="not a usable ONNX model"):
        ForceModel(tmp_path / "junk.onnx")


# --- command line -------------------------------------------------------------------------

def _run(argv):
    p = argparse.ArgumentParser(prog="fingertip")
    add_parsers(p.add_subparsers(dest="command", required=True))
    args = p.parse_args(argv)
    return run_command(args.func, args)  # errors mapped as the command line maps them


@pytest.fixture(scope="module")
def sim_dataset(tmp_path_factory):
    dataset = pytest.importorskip("fingertip.sim.dataset")
    out = tmp_path_factory.mktemp("cal") / "ds"
    dataset.write_calibration(out, units=1, seed=8)
    return out


def test_cli_fit(sim_dataset, tmp_path, capsys):
    out = tmp_path / "out"
    rc = _run(["calibrate", "fit", str(sim_dataset), "-o", str(out), "--models",
               "affine,poly2", "--bound", "25"])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    assert "| affine |" in cap.out and "chosen:" in cap.out and "within 25 %" in cap.out
    assert "[1/2] fitting affine" in cap.err and "[2/2] poly2" in cap.err
    assert "timing 2 model(s)" in cap.err
    rep = json.loads((out / "calibration.json").read_text())
    assert rep["chosen"] in ("affine", "poly2") and rep["bound_pct"] == 25
    assert ForceModel(out / "force.onnx").kind == rep["chosen"]
    rc = _run(["calibrate", "fit", str(sim_dataset / "unit_8.csv"), "-o", str(out),
               "--models", "affine", "--json", "-q"])
    cap = capsys.readouterr()
    assert rc == 0 and cap.err == "" and json.loads(cap.out)["chosen_index"] == 0
    assert _run(["calibrate", "check", str(sim_dataset)]) == 0
    assert capsys.readouterr().out.startswith("ok: 2640 rows")


def test_cli_refusals(sim_dataset, tmp_path, caplog, capsys):
    caplog.set_level(logging.ERROR, logger="fingertip")
    s = VirtualStrainSensor(2)
    sw = calibration_sweep(s, seed=1, angles_deg=(30,))
    lines = ["c0,c1,c2,c3,fx,fy,angle_deg,height_mm"] + [
        ",".join(str(int(v)) for v in c) + f",{float(fx)!r},{float(fy)!r},{a},{h}"
        for c, fx, fy, a, h in zip(sw.counts - sw.counts[0], sw.fx, sw.fy, sw.angle_deg,
                                   sw.height_mm, strict=True)]
    one = tmp_path / "one_angle.csv"
    one.write_text("\n".join(lines) + "\n")
    assert _run(["calibrate", "fit", str(one), "-o", str(tmp_path / "x"), "-q"]) == 2
    assert "[single_angle]" in caplog.text and "one direction" in caplog.text
    assert not (tmp_path / "x").exists()
    assert _run(["calibrate", "check", str(tmp_path / "missing.csv")]) == 2
    assert "[format]" in caplog.text
    with pytest.raises(SystemExit) as e:
        _run(["calibrate", "fit", str(sim_dataset), "--models", "svm"])
    assert e.value.code == 2 and "unknown model" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        _run(["calibrate", "fit", str(sim_dataset), "--bound", "-1"])


def test_runtime_needs_only_numpy_and_onnxruntime(model_file):
    import subprocess
    import sys

    code = (
        "import sys\n"
        "from fingertip.models.force.runtime import ForceModel\n"
        f"fm = ForceModel({str(model_file[0])!r})\n"
        "fm.estimate([1000, 0, -1000, 0]); fm.estimate([[1000, 0, -1000, 0]] * 3)\n"
        "print(sorted(m for m in ('onnx', 'scipy', 'matplotlib', 'sklearn', 'torch')\n"
        "             if m in sys.modules))\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[]"
