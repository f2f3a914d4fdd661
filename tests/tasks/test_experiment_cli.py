"""``fingertip experiment``: runs, prints the paper's tables, refuses bad arguments."""
from __future__ import annotations

import re

import json

import pytest

from fingertip.cli import main


def test_pinch_prints_the_table(capsys):
    assert main(["experiment", "pinch", "--trials", "2", "--seed", "3", "--object", "chip",
                 "-q"]) == 0
    out = capsys.readouterr().out
    assert ("| object | demonstrated at | F_th (estimated) | trials | success | broken | "
            "dropped |") in out
    assert re.search(r"\| chip \| 0\.1 N \| 0\.[01]\d\d N \| 2 \| 2/2 \| 0 \| 0 \|", out), out
    assert "tofu" not in out.split("\n\n", 1)[1]


def test_pinch_with_a_given_threshold_skips_the_demonstration(capsys):
    assert main(["experiment", "pinch", "--trials", "1", "--object", "chip", "--threshold",
                 "0.1", "-q"]) == 0
    assert "| chip | - | 0.100 N | 1 | 1/1 |" in capsys.readouterr().out


def test_cups_writes_json(tmp_path, capsys):
    path = tmp_path / "sub" / "cups.json"
    assert main(["experiment", "cups", "--trials", "3", "--json", str(path), "-q"]) == 0
    out = capsys.readouterr().out
    assert "| counted and lifted (the paper's 36/36) | 3/3 |" in out
    data = json.loads(path.read_text())
    assert data["protocol"] == "cups" and data["summary"]["success"] == 3
    assert [t["seed"] for t in data["trials"]] == [0, 1, 2]


def test_shake_prints_the_papers_table(capsys):
    assert main(["experiment", "shake", "--trials", "2", "--seed", "10"]) == 0
    cap = capsys.readouterr()
    assert "| Metric | Screw-filled box | Rubber-band box |" in cap.out
    assert "| Success rate | " in cap.out and "overall: " in cap.out
    assert "experiment shake: 2/2" in cap.err                    # progress on stderr


@pytest.mark.parametrize("argv, message", [
    (["experiment", "pinch", "--trials", "0"], "at least 1"),
    (["experiment", "pinch", "--trials", "x"], "invalid integer"),
    (["experiment", "cups", "--seed", "-1"], "at least 0"),
    (["experiment", "cups", "--trials", "nan"], "invalid integer"),
    (["experiment", "juggle"], "invalid choice"),
    (["experiment", "pinch", "--object", "egg"], "invalid choice"),
    (["experiment"], "required"),
])
def test_bad_arguments_are_refused(argv, message, capsys):
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    assert message in capsys.readouterr().err


def test_unwritable_json_is_a_user_error(tmp_path, caplog):
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["experiment", "pinch", "--trials", "1", "--json",
                 str(blocker / "out.json"), "-q"]) == 2
    assert "cannot write" in caplog.text
