"""Every command that loads a model, a recording, a dataset or a configuration, given an
empty, a truncated, a random or a wrong-kind file (and an ONNX graph of the wrong kind or
input shape): one clear ERROR line naming the file, exit status 2, no traceback. Run as
subprocesses of the real ``fingertip`` command, as a user would.

Two truncations are readable on purpose and are checked as such: an MCAP recording cut
short (a killed recorder's file) replays and exports up to its last complete chunk, and a
WAV file cut short is used with a warning, both saying so on one line.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fingertip.sim import VirtualFirmware
from fingertip.sim.pty_device import PtyDevice

KINDS = ("empty", "truncated", "random", "wrong")


def fingertip(*argv) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "fingertip.cli", *map(str, argv)],
                          capture_output=True, text=True, timeout=180,
                          env={**os.environ, "COLUMNS": "200"})


def assert_one_line(r: subprocess.CompletedProcess, names: Path) -> str:
    """Exit 2, exactly one ERROR line that names the file, only log lines on stderr."""
    lines = [x for x in r.stderr.splitlines() if x.strip()]
    assert "Traceback" not in r.stderr, r.stderr
    assert r.returncode == 2, (r.returncode, r.stderr)
    errors = [x for x in lines if x.startswith("ERROR fingertip: ")]
    assert len(errors) == 1, lines
    assert all(x.startswith(("ERROR ", "WARNING ")) for x in lines), lines
    assert names.name in errors[0], errors[0]
    assert len(errors[0]) < 420
    return errors[0]


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> dict[str, Path]:
    """One valid file of each kind: recording, material model, force model, WAV, CSV."""
    from fingertip.models.force.calibrate import fit_affine, from_arrays, model_metadata
    from fingertip.models.vibration.material import train_material
    from fingertip.record import Recorder
    from fingertip.sim.dataset import write_vibration
    from fingertip.sim.physics import VirtualStrainSensor, calibration_sweep
    from fingertip import Fingertip

    d = tmp_path_factory.mktemp("good")
    write_vibration(d / "vib", recordings_per_class=3, seconds=0.6, seed=1)
    train_material(d / "vib", d / "mat", epochs=20, plot=False)
    s = VirtualStrainSensor(4)
    sw = calibration_sweep(s, seed=4, angles_deg=(-40, 0, 40), heights_mm=(1, 3))
    data = from_arrays(sw.counts, sw.fx, sw.fy, angle_deg=sw.angle_deg,
                       height_mm=sw.height_mm, trial=sw.trial)
    m = fit_affine(data.counts, data.force)
    m.to_onnx(d / "force.onnx", model_metadata(m, data, data))
    with open(d / "cal.csv", "w") as f:
        f.write("c0,c1,c2,c3,fx,fy\n")
        for c, fo in zip(data.counts, data.force, strict=True):
            f.write(",".join(f"{v:.0f}" for v in c) + f",{fo[0]:.4f},{fo[1]:.4f}\n")
    with PtyDevice(VirtualFirmware(4), link=d / "tty") as dev, \
            Fingertip(str(dev.link)) as ft:
        rec = Recorder(d / "run.mcap").start()
        rec.attach(ft, "index")
        ft.start()
        import time
        time.sleep(1.0)
        ft.stop()
        rec.close()
    return {"mcap": d / "run.mcap", "material": d / "mat" / "material.onnx",
            "force": d / "force.onnx", "wav": next((d / "vib").rglob("*.wav")),
            "csv": d / "cal.csv", "toml": Path(__file__).parents[2] / "host" / "fingertip"
            / "sim" / "physics" / "fingertip.toml", "vib": d / "vib"}


def bad_file(tmp_path: Path, kind: str, like: Path, wrong: Path, suffix: str) -> Path:
    data = {"empty": b"", "truncated": like.read_bytes()[:like.stat().st_size // 2],
            "random": np.random.default_rng(7).bytes(4096),
            "wrong": wrong.read_bytes()}[kind]
    p = tmp_path / f"{kind}{suffix}"
    p.write_bytes(data)
    return p


def wrong_shape(model: Path, out: Path, n_in: int, n_out: int) -> Path:
    """A graph taking ``n_in`` values and giving ``n_out`` (a slice of the input), wearing
    the metadata of the real ``model``."""
    onnx = pytest.importorskip("onnx")
    from onnx import TensorProto, helper, numpy_helper

    meta = {p.key: p.value for p in onnx.load(str(model)).metadata_props}
    idx = numpy_helper.from_array(np.arange(n_out, dtype=np.int64) % n_in, "idx")
    g = helper.make_graph(
        [helper.make_node("Gather", ["x", "idx"], ["y"], axis=1)], "g",
        [helper.make_tensor_value_info("x", TensorProto.FLOAT, ["batch", n_in])],
        [helper.make_tensor_value_info("y", TensorProto.FLOAT, ["batch", n_out])], [idx])
    m = helper.make_model(g, opset_imports=[helper.make_opsetid("", 17)])
    m.ir_version = 9
    helper.set_model_props(m, meta)
    onnx.save(m, str(out))
    return out


# --- models -------------------------------------------------------------------------------

@pytest.mark.parametrize("kind", KINDS)
def test_classify_model(good, tmp_path, kind):
    # wrong kind: a force model where a material classifier is expected
    p = bad_file(tmp_path, kind, good["material"], good["force"], ".onnx")
    assert_one_line(fingertip("classify", "material", p, good["wav"]), p)


def test_classify_model_of_the_other_kind_and_wrong_shape(good, tmp_path):
    line = assert_one_line(fingertip("classify", "shake", good["material"], good["wav"]),
                           good["material"])
    assert "material model, not a shake model" in line
    p = wrong_shape(good["material"], tmp_path / "shape.onnx", 7, 7)
    line = assert_one_line(fingertip("classify", "material", p, good["wav"]), p)
    assert "shape (7)" in line


@pytest.mark.parametrize("kind", [*KINDS, "classifier", "shape"])
def test_record_force_model(good, tmp_path, kind):
    """The model is loaded before any device is opened: no device needed to refuse it."""
    like = good["force"]
    p = (good["material"] if kind == "classifier" else
         wrong_shape(like, tmp_path / "f3.onnx", 3, 2) if kind == "shape" else
         bad_file(tmp_path, kind, like, good["wav"], ".onnx"))
    line = assert_one_line(fingertip("record", "--port", tmp_path / "no-such-port", "-o",
                                     tmp_path / "r.mcap", "--force-model", p), p)
    assert "no-such-port" not in line
    if kind == "shape":
        assert "the graph takes 3" in line
    if kind == "classifier":
        assert "not a force model" in line
    assert not (tmp_path / "r.mcap").exists()


# --- recordings ---------------------------------------------------------------------------

@pytest.mark.parametrize("command", ["replay", "export"])
@pytest.mark.parametrize("kind", KINDS)
def test_recording(good, tmp_path, kind, command):
    p = bad_file(tmp_path, kind, good["mcap"], good["material"], ".mcap")
    argv = ([command, p, "--as-fast-as-possible"] if command == "replay"
            else [command, p, "-o", tmp_path / "out"])
    r = fingertip(*argv)
    if kind == "truncated":  # a killed recorder's file: read up to its last whole chunk
        assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
        assert "cut short" in r.stderr
    else:
        assert_one_line(r, p)


@pytest.mark.parametrize("kind", KINDS)
def test_audio_file(good, tmp_path, kind):
    p = bad_file(tmp_path, kind, good["wav"], good["mcap"], ".wav")
    r = fingertip("classify", "material", good["material"], p)
    if kind == "truncated":
        assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
        assert "is cut short: its header announces" in r.stderr
    else:
        assert_one_line(r, p)
        assert_one_line(fingertip("record", "--port", tmp_path / "no-port", "-o",
                                  tmp_path / "r.mcap", "--audio-file", p), p)


# --- datasets -----------------------------------------------------------------------------

@pytest.mark.parametrize("kind", KINDS)
def test_calibration_dataset(good, tmp_path, kind):
    p = bad_file(tmp_path, kind, good["csv"], good["wav"], ".csv")
    assert_one_line(fingertip("calibrate", "check", p), p)
    if kind == "random":
        assert_one_line(fingertip("calibrate", "fit", p, "-o", tmp_path / "o", "-q"), p)


@pytest.mark.parametrize("kind", KINDS)
def test_training_folder_of_bad_recordings(good, tmp_path, kind):
    """A dataset whose recordings are all unusable: each is named in a warning (what was
    skipped), then one error; a file given instead of a folder: one error."""
    folder = tmp_path / "ds"
    for c in ("a", "b"):
        (folder / c).mkdir(parents=True)
        p = bad_file(folder / c, kind, good["wav"], good["mcap"], ".wav")
    r = fingertip("train", "material", folder, "-o", tmp_path / "m", "--epochs", "5")
    if kind == "truncated":  # 0.3 s halves: usable recordings (with a warning each)
        assert "Traceback" not in r.stderr and "cut short" in r.stderr
        assert r.returncode in (0, 2), r.stderr
    else:
        line = assert_one_line(r, folder)
        assert "fewer than two classes" in line
        assert r.stderr.count("WARNING") == 2
    assert_one_line(fingertip("train", "shake", p, "-o", tmp_path / "s"), p)


def test_training_folder_keeps_going_past_one_bad_file(good, tmp_path):
    folder = tmp_path / "ds"
    shutil.copytree(good["vib"], folder)
    bad = folder / "tpu" / "broken.wav"
    bad.write_bytes(np.random.default_rng(1).bytes(2000))
    r = fingertip("train", "material", folder, "-o", tmp_path / "m", "--epochs", "5")
    assert r.returncode == 0, r.stderr
    warns = [x for x in r.stderr.splitlines() if x.startswith("WARNING")]
    assert len(warns) == 1 and "broken.wav" in warns[0] and "skipped" in warns[0]


# --- configuration ------------------------------------------------------------------------

@pytest.mark.parametrize("kind", KINDS)
def test_simulator_parameters(good, tmp_path, kind):
    p = bad_file(tmp_path, kind, good["toml"], good["csv"], ".toml")
    assert_one_line(fingertip("sim", "dataset", "calibration", tmp_path / "o", "--params", p),
                    p)
    assert not any((tmp_path / "o").glob("*.csv"))


# --- firmware image -----------------------------------------------------------------------

@pytest.mark.parametrize("kind", KINDS)
def test_flash_hex(good, tmp_path, kind):
    hex_text = b":100000000C945C000C946E000C946E000C946E00CA\n:00000001FF\n"
    like = tmp_path / "good.hex"
    like.write_bytes(hex_text)
    p = bad_file(tmp_path, kind, like, good["wav"], ".hex")
    assert_one_line(fingertip("flash", "--hex", p, "--dry-run"), p)
