"""A fitted model's cache key changes with every input of the fit (no stale fit reused)."""
from __future__ import annotations

from pathlib import Path

import pytest

from fingertip.models.nets import fit_cache
from fingertip.models.nets.fit_cache import fit_key


@pytest.fixture
def src(tmp_path: Path) -> Path:
    d = tmp_path / "pkg"
    (d / "sub").mkdir(parents=True)
    (d / "a.py").write_text("X = 1\n")
    (d / "sub" / "b.toml").write_text("k = 2\n")
    (d / "notes.txt").write_text("not an input\n")
    return d


PARAMS = {"unit_seed": 100, "epochs": 300}


def test_same_inputs_same_key(src: Path) -> None:
    assert fit_key(PARAMS, [src], "0.1.0") == fit_key(dict(PARAMS), [src], "0.1.0")


@pytest.mark.parametrize("change", ["param", "seed", "version", "source", "data", "new_file",
                                    "rename", "library"])
def test_each_input_changes_the_key(src: Path, change: str,
                                    monkeypatch: pytest.MonkeyPatch) -> None:
    before = fit_key(PARAMS, [src], "0.1.0")
    params, version = dict(PARAMS), "0.1.0"
    if change == "param":
        params["epochs"] = 301
    elif change == "seed":
        params["unit_seed"] = 101
    elif change == "version":
        version = "0.1.1"
    elif change == "source":
        (src / "a.py").write_text("X = 2\n")
    elif change == "data":
        (src / "sub" / "b.toml").write_text("k = 3\n")
    elif change == "new_file":
        (src / "c.py").write_text("\n")
    elif change == "rename":
        (src / "a.py").rename(src / "a2.py")
    elif change == "library":
        real = fit_cache.library_versions
        monkeypatch.setattr(fit_cache, "library_versions",
                            lambda names=fit_cache.DEFAULT_LIBRARIES:
                            {**real(names), "numpy": "0.0.0"})
    assert fit_key(params, [src], version) != before


def test_unrelated_file_does_not_change_the_key(src: Path) -> None:
    before = fit_key(PARAMS, [src], "0.1.0")
    (src / "notes.txt").write_text("edited\n")
    assert fit_key(PARAMS, [src], "0.1.0") == before


def test_key_does_not_depend_on_the_checkout_path(src: Path, tmp_path: Path) -> None:
    other = tmp_path / "elsewhere" / "pkg"
    other.parent.mkdir()
    src.rename(other)
    (tmp_path / "pkg").mkdir()
    for f in other.rglob("*"):
        if f.is_file():
            dst = tmp_path / "pkg" / f.relative_to(other)
            dst.parent.mkdir(parents=True, exist_ok=True)
            dst.write_bytes(f.read_bytes())
    assert fit_key(PARAMS, [other], "v") == fit_key(PARAMS, [tmp_path / "pkg"], "v")


def test_bad_input_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="does not exist"):
        fit_key(PARAMS, [tmp_path / "missing"], "v")
    with pytest.raises(ValueError, match="not plain JSON"):
        fit_key({"x": object()}, [tmp_path], "v")
    with pytest.raises(ValueError, match="not plain JSON"):
        fit_key({"x": float("nan")}, [tmp_path], "v")


def test_unit_force_model_is_cached_under_its_key(tmp_path: Path,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """The real simulated unit's model lands in a folder named by its key, and a stale
    folder named by the seed alone (the old layout) is not used."""
    from fingertip.sim.world import hand as sim_world

    monkeypatch.setenv("FINGERTIP_TASKS_CACHE", str(tmp_path))
    stale = tmp_path / "unit100"
    stale.mkdir()
    (stale / "force.onnx").write_bytes(b"stale")
    m = sim_world.unit_force_model(100)
    made = [p.name for p in tmp_path.iterdir() if p.name.startswith("unit100-")]
    assert len(made) == 1 and len(made[0]) == len("unit100-") + fit_cache.KEY_CHARS
    assert m.path.parent.name == made[0]


def test_shake_model_is_cached_under_its_key(tmp_path: Path,
                                             monkeypatch: pytest.MonkeyPatch) -> None:
    """The simulated world's shake classifier is keyed like the force models: a stale entry
    named by its seed and size alone (the old layout) is not used."""
    from fingertip.sim.world import boxes

    monkeypatch.setenv("FINGERTIP_TASKS_CACHE", str(tmp_path))
    stale = tmp_path / f"shake-mlp-{boxes.SHAKE_MODEL_SEED}-2"
    stale.mkdir()
    (stale / "shake_mlp.onnx").write_bytes(b"stale")
    path = boxes.shake_model_path(recordings_per_class=2)
    assert path.parent != stale and path.read_bytes() != b"stale"
    assert len(path.parent.name) == len(stale.name) + 1 + fit_cache.KEY_CHARS
