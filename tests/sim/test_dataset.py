"""`fingertip sim dataset calibration|vibration`: files, formats, reproducibility, errors."""
from __future__ import annotations

import csv
import filecmp
import hashlib
import json
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from fingertip.cli.sim import main
from fingertip.sim.dataset import (
    CALIBRATION_COLUMNS, MANIFEST_COLUMNS, TASK_AMPLITUDE_GAIN, TASK_BOX_ITEMS, DatasetError,
    plan_vibration, read_calibration_csv, resample, write_calibration, write_vibration,
)
from fingertip.sim.physics import PAPER_SEVEN, params_path


def run(*argv: str) -> int:
    return main(["dataset", *argv])


def rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def tree(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob("*") if p.is_file())


# --- calibration --------------------------------------------------------------------------

@pytest.fixture(scope="module")
def cal(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("cal") / "sweeps"
    assert run("calibration", str(out), "--units", "2", "--seed", "3", "-q") == 0
    return out


def test_calibration_files_and_columns(cal):
    assert tree(cal) == ["dataset.json", "unit_3.csv", "unit_4.csv"]
    meta = json.loads((cal / "dataset.json").read_text())
    assert meta["complete"] and meta["kind"] == "calibration" and meta["units"] == [3, 4]
    assert (meta["rate_sps"], meta["gain"], meta["channels"]) == (80, 128, 4)
    assert meta["params_sha256"] == hashlib.sha256(params_path().read_bytes()).hexdigest()
    assert list(meta["columns"]) == list(CALIBRATION_COLUMNS)
    for unit in (3, 4):
        with open(cal / f"unit_{unit}.csv", newline="") as f:
            assert next(csv.reader(f)) == list(CALIBRATION_COLUMNS)
        d = read_calibration_csv(cal / f"unit_{unit}.csv")
        n = 11 * 6 * 40  # angles x heights x (20 steps in + 20 out)
        assert len(d["fx"]) == n == meta["rows"][f"unit_{unit}.csv"]
        assert sorted(set(d["angle_deg"])) == list(range(-50, 51, 10))
        assert sorted(set(d["height_mm"])) == [0, 1, 2, 3, 4, 5]
        assert set(d["phase"]) == {"loading", "unloading"}
        assert np.allclose(np.unique(d["displacement_mm"]), 1.5 * np.arange(0, 21))
        assert set(d["unit_seed"]) == {unit} and set(d["sweep"]) == {0}
        for c in ("device_time_us", "ch0", "ch1", "ch2", "ch3", "seq"):
            assert d[c].dtype == np.int64, c
        assert np.all(np.diff(d["device_time_us"]) > 0)
        mag = np.hypot(d["fx"], d["fy"])
        assert mag.max() <= 5.0 and mag.max() > 4.4
        # The real direction: the nominal one plus the fixture's spread (2 deg, 1 sigma).
        ang = np.degrees(np.arctan2(d["fy"], d["fx"]))[mag > 0.5]
        assert np.abs(ang - d["angle_deg"][mag > 0.5]).max() < 10
        # Tared: near zero without load; and the counts carry the force (affine fit).
        counts = np.column_stack([d[f"ch{i}"] for i in range(4)]).astype(float)
        # (before the first contact: later the room's temperature moves the zero, mostly in
        # common mode, by ~60k counts per kelvin, and creep recovery follows each unloading)
        first = (d["device_time_us"] < d["device_time_us"][0] + 300_000_000) \
            & (d["phase"] == "loading")
        assert np.abs(counts[(mag == 0) & first]).max() < 30_000
        a = np.column_stack([counts, np.ones(n)])
        coef, *_ = np.linalg.lstsq(a, np.column_stack([d["fx"], d["fy"]]), rcond=None)
        rmse = np.sqrt(np.mean((a @ coef - np.column_stack([d["fx"], d["fy"]])) ** 2))
        assert rmse < 0.5, rmse


def test_calibration_units_differ_and_seed_reproduces(cal, tmp_path):
    a, b = (read_calibration_csv(cal / f"unit_{u}.csv") for u in (3, 4))
    assert not np.array_equal(a["ch0"], b["ch0"])
    assert run("calibration", str(tmp_path / "again"), "--units", "2", "--seed", "3",
               "-q") == 0
    for name in ("unit_3.csv", "unit_4.csv", "dataset.json"):
        assert filecmp.cmp(cal / name, tmp_path / "again" / name, shallow=False), name


def test_calibration_options(tmp_path):
    res = write_calibration(tmp_path / "raw", seed=1, sweeps=2, tare_samples=0,
                            samples_per_step=2, rate_sps=10)
    d = read_calibration_csv(tmp_path / "raw" / "unit_1.csv")
    assert len(d["fx"]) == 2 * 2 * 2640 and set(d["sweep"]) == {0, 1}
    assert res.meta["tare_offsets"]["unit_1.csv"] == [0, 0, 0, 0]
    idle = np.column_stack([d[f"ch{i}"] for i in range(4)])[np.hypot(d["fx"], d["fy"]) == 0]
    assert np.abs(idle).mean() > 30_000  # untared: the offsets of glue, resistors, ADC
    # The two sweeps draw their own trial orders; time runs on across them.
    order = [list(zip(d["angle_deg"][d["sweep"] == k][::80],
                      d["height_mm"][d["sweep"] == k][::80], strict=True)) for k in (0, 1)]
    assert order[0] != order[1] and sorted(order[0]) == sorted(order[1])
    assert np.all(np.diff(d["device_time_us"]) > 0)


# --- vibration ----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def materials(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("vib") / "materials"
    assert run("vibration", str(out), "--kind", "materials", "--recordings-per-class", "2",
               "--seconds", "0.3", "--seed", "5", "-q") == 0
    return out


def test_materials_layout_wav_and_manifest(materials):
    assert sorted(p.name for p in materials.iterdir() if p.is_dir()) == sorted(PAPER_SEVEN)
    man = rows(materials / "manifest.csv")
    assert list(man[0]) == list(MANIFEST_COLUMNS) and len(man) == 14
    assert [r["class"] for r in man] == [c for c in PAPER_SEVEN for _ in range(2)]
    assert len({r["seed"] for r in man}) == 14
    for r in man:
        info = sf.info(str(materials / r["file"]))
        assert (info.format, info.subtype, info.samplerate, info.channels) == \
            ("WAV", "PCM_16", 44100, 1)
        assert info.frames == int(r["frames"]) == round(0.3 * 44100)
        assert Path(r["file"]).parent.name == r["class"]
        p = json.loads(r["params"])
        assert p["material"] == r["class"] and p["seed"] == int(r["seed"])
        assert 10 <= float(r["speed_mm_s"]) <= 40 and 0.5 <= float(r["normal_n"]) <= 2
        assert -70 < float(r["rms_dbfs"]) < -10
    # Speeds and forces vary within a class, so its recordings differ.
    x0, _ = sf.read(str(materials / man[0]["file"]), dtype="int16")
    x1, _ = sf.read(str(materials / man[1]["file"]), dtype="int16")
    assert man[0]["speed_mm_s"] != man[1]["speed_mm_s"] and not np.array_equal(x0, x1)
    meta = json.loads((materials / "dataset.json").read_text())
    assert meta["complete"] and meta["classes"] == list(PAPER_SEVEN)
    assert sorted(meta["files"] + ["dataset.json"]) == tree(materials)


def test_same_seed_same_bytes_other_seed_other_data(materials, tmp_path):
    args = ["--kind", "materials", "--recordings-per-class", "2", "--seconds", "0.3", "-q"]
    assert run("vibration", str(tmp_path / "a"), *args, "--seed", "5") == 0
    cmp = filecmp.dircmp(materials, tmp_path / "a")
    assert tree(materials) == tree(tmp_path / "a")
    for f in tree(materials):
        assert filecmp.cmp(materials / f, tmp_path / "a" / f, shallow=False), f
    assert not cmp.diff_files
    assert run("vibration", str(tmp_path / "b"), *args, "--seed", "6") == 0
    x, _ = sf.read(str(materials / "tpu" / "tpu_0000.wav"), dtype="int16")
    y, _ = sf.read(str(tmp_path / "b" / "tpu" / "tpu_0000.wav"), dtype="int16")
    assert not np.array_equal(x, y)


def test_other_rate_and_flac(tmp_path):
    out = tmp_path / "low"
    assert run("vibration", str(out), "--recordings-per-class", "1", "--seconds", "0.5",
               "--rate", "16000", "--format", "flac", "-q") == 0
    man = rows(out / "manifest.csv")
    assert len(man) == 7
    for r in man:
        info = sf.info(str(out / r["file"]))
        assert r["file"].endswith(".flac") and info.format == "FLAC"
        assert (info.samplerate, info.frames, info.subtype) == (16000, 8000, "PCM_16")
    # Resampled from the same simulation as the 44.1 kHz file (same seed and parameters).
    hi = write_vibration(tmp_path / "hi", recordings_per_class=1, seconds=0.5).out
    a, _ = sf.read(str(hi / "tpu" / "tpu_0000.wav"))
    b, _ = sf.read(str(out / "tpu" / "tpu_0000.flac"))
    ref = resample(a, 44100, 16000)
    assert np.corrcoef(ref, b)[0, 1] > 0.999


def test_shake_classes_and_paper_duration(tmp_path):
    out = tmp_path / "shake"
    assert run("vibration", str(out), "--kind", "shake", "--recordings-per-class", "1",
               "-q") == 0
    man = rows(out / "manifest.csv")
    assert [r["class"] for r in man] == ["screws", "rubber_bands", "empty"]
    for r in man:
        assert sf.info(str(out / r["file"])).frames == round(5.6 * 44100)
        p = json.loads(r["params"])
        assert (p["frequency_hz"], p["amplitude_m"], p["duration"]) == (0.67, 0.05, 5.6)
        assert 1.0 <= float(r["normal_n"]) <= 2.0  # the grip
    level = {r["class"]: float(r["rms_dbfs"]) for r in man}
    assert level["screws"] > level["rubber_bands"] > level["empty"] - 3


def test_shake_task_variation_draws_the_scenes_fill_and_amplitude():
    plain = plan_vibration("shake", 30, None, 3)
    varied = plan_vibration("shake", 30, None, 3, task_variation=True)
    for a, b in zip(plain, varied, strict=True):
        # the grip is drawn first either way: the paper-like set stays as it was
        assert a.scene.grip_n == b.scene.grip_n and a.scene.items is None
        lo, hi = TASK_BOX_ITEMS[b.cls]
        assert lo <= b.scene.n_items <= hi
        g = b.scene.amplitude_m / a.scene.amplitude_m
        assert TASK_AMPLITUDE_GAIN[0] - 1e-4 <= g <= TASK_AMPLITUDE_GAIN[1] + 1e-4
    screws = {p.scene.n_items for p in varied if p.cls == "screws"}
    assert len(screws) > 3  # the fill really varies, not one default
    assert {p.scene.n_items for p in varied if p.cls == "empty"} == {0}


def test_task_variation_is_for_shakes_only(tmp_path):
    with pytest.raises(DatasetError, match="shake recordings only"):
        write_vibration(tmp_path / "a", kind="materials", task_variation=True)
    assert not (tmp_path / "a").exists()


def test_cups_sidecars(tmp_path):
    out = tmp_path / "cups"
    assert run("vibration", str(out), "--kind", "cups", "--recordings-per-class", "2",
               "--rate", "22050", "-q") == 0
    assert tree(out) == ["cups/cups_0000.wav", "cups/cups_0000_rims.csv",
                         "cups/cups_0000_z.csv", "cups/cups_0001.wav",
                         "cups/cups_0001_rims.csv", "cups/cups_0001_z.csv", "dataset.json",
                         "manifest.csv"]
    for r in rows(out / "manifest.csv"):
        stem = out / r["file"][:-4]
        rims = rows(Path(f"{stem}_rims.csv"))
        assert len(rims) == 5 and [x["passed"] for x in rims] == ["1", "1", "1", "0", "0"]
        p = json.loads(r["params"])
        assert 5 <= p["speed_mm_s"] <= 20 and 100 <= p["z_start_mm"] <= 140
        z = rows(Path(f"{stem}_z.csv"))
        tz = np.array([float(x["time_s"]) for x in z])
        zz = np.array([float(x["z_mm"]) for x in z])
        assert zz[0] == pytest.approx(p["z_start_mm"]) and np.all(np.diff(zz) <= 0)
        for x in rims[:3]:
            t = float(x["time_s"])
            assert int(x["sample"]) == round(t * 22050)
            assert np.interp(t, tz, zz) == pytest.approx(float(x["z_mm"]), abs=1e-3)
        duration = float(r["duration_s"])
        assert duration == pytest.approx(0.6 + 21 / p["speed_mm_s"], abs=1e-3)


# --- errors -------------------------------------------------------------------------------

def test_non_empty_folder_is_refused_unless_force(materials, tmp_path, caplog):
    out = tmp_path / "ds"
    assert run("vibration", str(out), "--recordings-per-class", "1", "--seconds", "0.2",
               "-q") == 0
    before = tree(out)
    assert run("vibration", str(out), "--kind", "shake", "-q") == 2
    assert "is not empty" in caplog.text and "--force" in caplog.text
    assert tree(out) == before
    # --force replaces this command's dataset: no stale class folder survives.
    assert run("vibration", str(out), "--kind", "shake", "--recordings-per-class", "1",
               "--seconds", "0.2", "--force", "-q") == 0
    assert sorted(p.name for p in out.iterdir()) == ["dataset.json", "empty", "manifest.csv",
                                                     "rubber_bands", "screws"]
    # Files it did not write are never deleted, and reported.
    (out / "notes.txt").write_text("mine")
    caplog.clear()
    assert run("calibration", str(out), "--force", "-q") == 0
    assert tree(out) == ["dataset.json", "notes.txt", "unit_0.csv"]
    assert "did not write" in caplog.text and "notes.txt" in caplog.text


def test_interrupted_run_is_marked_and_replaceable(tmp_path):
    out = tmp_path / "cut"

    def interrupt(rel: str) -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_vibration(out, recordings_per_class=3, seconds=0.2, on_recording=interrupt)
    assert json.loads((out / "dataset.json").read_text())["complete"] is False
    with pytest.raises(DatasetError, match="not empty"):
        write_vibration(out, recordings_per_class=1, seconds=0.2)
    write_vibration(out, kind="shake", recordings_per_class=1, seconds=0.2, force=True)
    assert not (out / "tpu").exists() and (out / "screws").is_dir()


def test_unwritable_or_wrong_output(tmp_path, caplog):
    f = tmp_path / "file.txt"
    f.write_text("x")
    assert run("calibration", str(f), "-q") == 2
    assert "is not a folder" in caplog.text
    caplog.clear()
    assert run("vibration", str(f / "sub"), "-q") == 2
    assert "cannot write into" in caplog.text
    with pytest.raises(DatasetError, match="cannot write into") as e:
        write_calibration(f / "sub")
    assert e.value.code == 2


@pytest.mark.parametrize("argv,match", [
    (["vibration", "--kind", "cups", "--seconds", "2"], "does not apply to cups"),
    (["calibration", "--params", "/nonexistent.toml"], "cannot read /nonexistent.toml"),
])
def test_bad_combinations_are_clear(tmp_path, caplog, argv, match):
    kind, *rest = argv
    assert run(kind, str(tmp_path / "x"), *rest, "-q") == 2
    assert match in caplog.text
    assert not (tmp_path / "x").exists()  # checked before anything is written


@pytest.mark.parametrize("argv", [
    ["calibration", "--units", "0"],
    ["calibration", "--rate-sps", "40"],
    ["calibration", "--max-force", "nan"],
    ["vibration", "--rate", "500"],
    ["vibration", "--seconds", "-1"],
    ["vibration", "--kind", "marbles"],
    ["vibration", "--recordings-per-class", "two"],
    ["vibration", "--seed", "-3"],
])
def test_bad_arguments_exit_2(tmp_path, capsys, argv):
    kind, *rest = argv
    with pytest.raises(SystemExit) as e:
        run(kind, str(tmp_path / "x"), *rest)
    assert e.value.code == 2
    assert "error: argument" in capsys.readouterr().err


def test_library_checks_arguments(tmp_path):
    with pytest.raises(DatasetError, match="rate"):
        write_vibration(tmp_path / "a", rate=100)
    with pytest.raises(DatasetError, match="kind"):
        write_vibration(tmp_path / "a", kind="marbles")
    with pytest.raises(DatasetError, match="units"):
        write_calibration(tmp_path / "a", units=0)
    assert not (tmp_path / "a").exists()


def test_progress_line_on_stderr(tmp_path, capsys):
    assert run("vibration", str(tmp_path / "p"), "--recordings-per-class", "1",
               "--seconds", "0.1") == 0
    cap = capsys.readouterr()
    assert "materials" in cap.err and "7/7 (100 %)" in cap.err
    assert "wrote 7 recordings in 7 classes" in cap.out


def test_resample_lengths_and_band_limit():
    fs = 44100
    t = np.arange(int(0.5 * fs)) / fs
    x = 0.5 * np.sin(2 * np.pi * 440 * t)
    for out in (2000, 16000, 48000):
        y = resample(x, fs, out)
        assert len(y) == round(len(x) * out / fs)
        ty = np.arange(len(y)) / out
        mid = slice(len(y) // 10, -len(y) // 10)
        assert np.abs(y - 0.5 * np.sin(2 * np.pi * 440 * ty))[mid].max() < 1e-3
    alias = resample(0.5 * np.sin(2 * np.pi * 15000 * t), fs, 16000)  # above 8 kHz: gone
    assert np.sqrt(np.mean(alias ** 2)) < 2e-3
    assert np.array_equal(resample(x, fs, fs), x)
