"""Where the vibration bench finds the hydrogen-drumkits files, and how their fetch fails.

Neither test needs the package: folders are made in tmp_path, and the fetch script meets a
stand-in apt-get that fails the way a machine without the package in its sources does.
"""
from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

from tests.bench import public_sets as ps

SCRIPT = Path(__file__).resolve().parents[2] / "tools" / "fetch-drumkits.sh"


def _kits(folder: Path) -> Path:
    (folder / ps.KNOCK_KIT).mkdir(parents=True)
    return folder


def test_explicit_folder_then_fetched_then_installed(tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    fetched, installed = tmp_path / "fetched", tmp_path / "installed"
    monkeypatch.setattr(ps, "FETCHED", fetched)
    monkeypatch.setattr(ps, "DRUMKITS", installed)
    assert ps.find_root() is None
    _kits(installed)
    assert ps.find_root() == installed
    _kits(fetched)
    assert ps.find_root() == fetched
    own = _kits(tmp_path / "own")
    assert ps.find_root(own) == own
    # an explicit folder without the kits is reported missing, never swapped for another copy
    assert ps.find_root(tmp_path / "empty") is None


def test_fetch_warns_in_one_line_and_leaves_nothing(tmp_path: Path) -> None:
    fake = tmp_path / "bin"
    fake.mkdir()
    apt = fake / "apt-get"
    apt.write_text("#!/bin/sh\necho \"E: Version '2017.09.19~dfsg-1' for 'hydrogen-drumkits'"
                   " was not found\" >&2\nexit 100\n")
    apt.chmod(0o755)
    dest = tmp_path / "drumkits"
    env = {**os.environ, "PATH": f"{fake}:{os.environ['PATH']}"}
    r = subprocess.run(["bash", str(SCRIPT), str(dest)], env=env, capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    warnings = [line for line in r.stderr.splitlines() if line.startswith("WARNING")]
    assert len(warnings) == 1 and "was not found" in warnings[0], r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bin"]
