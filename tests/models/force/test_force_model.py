"""``--force-model FORCE.onnx``: a model that does not belong to the fingertip is refused
with the reason; a good one gives newtons on stream and record."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from fingertip.models.force.calibrate import fit_model
from fingertip.models.force.runtime import ForceModel
from fingertip.models.force.force_load import ModelMismatch, check_model
from fingertip.sim.pty_device import PtyDevice
from fingertip.sim.bringup import VirtualUnit


def model(tmp_path, name="m.onnx", **meta):
    rng = np.random.default_rng(0)
    counts = rng.normal(0, 1e5, (200, 4))
    force = counts[:, :2] * 1e-5
    m = fit_model("affine", counts, force)
    base = {"fingertip_model": "force", "channels": 4, "units": "N", "counts_gain": 128}
    return m.to_onnx(tmp_path / name, {**base, **meta})


def test_matching_model_passes(tmp_path):
    fm = ForceModel(model(tmp_path, device_serial="A1"))
    assert check_model(fm, channels=4, serial="A1", gain=128) == []
    warn = check_model(fm, channels=4, serial="", gain=64)
    assert any("cannot be checked" in w for w in warn) and any("gain 64" in w for w in warn)


@pytest.mark.parametrize("meta,kw,match", [
    ({"device_serial": "A1"}, {"serial": "B2"}, "calibrated on device 'A1'"),
    ({"units": "lbf"}, {}, "not newtons"),
    ({}, {"channels": 16}, "takes 4 channels, this fingertip streams 16"),
])
def test_mismatch_refused_with_reason(tmp_path, meta, kw, match):
    fm = ForceModel(model(tmp_path, **meta))
    with pytest.raises(ModelMismatch, match=match):
        check_model(fm, **{"channels": 4, **kw})


def test_other_kind_refused_on_opening(tmp_path):
    with pytest.raises(ValueError, match="not a force model"):
        ForceModel(model(tmp_path, fingertip_model="material"))


def test_other_device_allowed_on_request(tmp_path):
    fm = ForceModel(model(tmp_path, device_serial="A1"))
    assert check_model(fm, channels=4, serial="B2", allow_other_device=True) == []


def run_cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "fingertip.cli", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=60)


def test_stream_and_record_with_an_onnx_model(tmp_path):
    good = model(tmp_path, "good.onnx")
    bad = model(tmp_path, "bad.onnx", units="kgf")
    with PtyDevice(VirtualUnit(0).firmware) as dev:
        r = run_cli("stream", "--port", dev.port, "--count", "3", "--json", "--force-model",
                    str(good), cwd=tmp_path)
        assert r.returncode == 0, r.stderr
        rows = [json.loads(x) for x in r.stdout.splitlines()]
        assert len(rows) == 3 and all(len(x["force_n"]) == 2 for x in rows)
        # The model is counts * 1e-5 on channels 0 and 1: the forces follow the counts.
        c = np.array(rows[0]["counts"], float)
        assert rows[0]["force_n"][0] == pytest.approx(c[0] * 1e-5, abs=1e-3)
        r = run_cli("stream", "--port", dev.port, "--count", "3", "--force-model", str(bad),
                    cwd=tmp_path)
        assert r.returncode == 2 and "refused" in r.stderr and "kgf" in r.stderr
        r = run_cli("record", "--port", dev.port, "-o", "x.mcap", "--duration", "1",
                    "--force-model", str(bad), cwd=tmp_path)
        assert r.returncode == 2 and "refused" in r.stderr
        assert not (tmp_path / "x.mcap").exists()
        r = run_cli("record", "--port", dev.port, "-o", "y.mcap", "--duration", "1",
                    "--force-model", str(good), cwd=tmp_path)
        assert r.returncode == 0, r.stderr
        out = r.stdout + r.stderr
        assert " 0 forces" not in out and " forces" in out


def test_force_window_over_real_frames(tmp_path):
    import time

    from fingertip.device import Fingertip
    from fingertip.models.force.force_load import ForceWindow

    fm = ForceModel(model(tmp_path))
    with PtyDevice(VirtualUnit(0).firmware) as dev, Fingertip(dev.port) as ft:
        w = ForceWindow(fm, seconds=5.0)
        ft.add_callback(w.add)
        ft.start()
        t0 = time.monotonic()
        time.sleep(0.6)
        t1 = time.monotonic()
        ft.stop()
    f = w.mean(t0, t1)
    assert f is not None and all(np.isfinite(f))
    assert w.mean(t1 + 10, t1 + 11) is None


def test_classify_force_model_refused_or_needs_port(tmp_path):
    bad = model(tmp_path, "bad.onnx", channels=4, units="lbf")
    r = run_cli("classify", "material", "m.onnx", "--simulate", "glass", "--force-model",
                str(bad), cwd=tmp_path)
    assert r.returncode == 2 and "needs --port" in r.stderr
    with PtyDevice(VirtualUnit(0).firmware) as dev:
        r = run_cli("classify", "material", "m.onnx", "--port", dev.port, "--force-model",
                    str(bad), cwd=tmp_path)
    assert r.returncode == 2 and "refused" in r.stderr and "lbf" in r.stderr
