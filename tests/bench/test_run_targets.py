"""The benchmark runner's targets: one-sided and ranges, judged and shown as the table does."""
from __future__ import annotations

import pytest

from tests.bench import bench_realism
from tests.bench.run import check_target, judge, show_target


def test_range_is_judged_on_both_ends() -> None:
    t = ("within", (0.10, 0.20))
    assert judge(0.10, t) == "met"
    assert judge(0.15, t) == "met"
    assert judge(0.20, t) == "met"
    assert judge(0.0999, t) == "MISSED"
    assert judge(0.213, t) == "MISSED"


def test_targets_are_shown_as_written_in_the_issues() -> None:
    assert show_target(("within", (0.10, 0.20))) == "0.10-0.20"
    assert show_target(("within", (0.93, 0.98))) == "0.93-0.98"
    assert show_target(("<=", 0.7)) == "<= 0.7"
    assert show_target((">=", 53)) == ">= 53"
    assert show_target(None) == ""


def test_one_sided_targets() -> None:
    assert judge(0.65, ("<=", 0.7)) == "met"
    assert judge(0.71, ("<=", 0.7)) == "MISSED"
    assert judge(1.0, (">", 1.0)) == "MISSED"
    assert judge(5, None) == ""


@pytest.mark.parametrize("target", [("between", (0, 1)), ("within", (0.2, 0.1)),
                                    ("within", 0.1)])
def test_malformed_targets_are_refused(target) -> None:
    with pytest.raises(SystemExit, match="target|within"):
        check_target("k", target)


def test_realism_goals_are_ranges() -> None:
    d = bench_realism.DESCRIPTION
    assert d["sim_paper_method_force_mse_n2"][1] == ("within", (0.10, 0.20))
    assert d["sim_paper_method_material_accuracy"][1] == ("within", (0.93, 0.98))
    for _, target in d.values():
        check_target("realism", target)


def test_ideal_sensor_rows_are_listed_apart(tmp_path, monkeypatch) -> None:
    from tests.bench import run

    monkeypatch.setattr(run, "MD_OUT", tmp_path / "b.md")
    meta = {"a_real": {"what": "realistic figure", "target": "0.10-0.20", "status": "met"},
            "b_ideal": {"what": "ideal sensor: old figure", "target": "", "status": ""}}
    run.write_markdown({"a_real": 0.15, "b_ideal": 0.02}, meta, {}, "Last run on: x")
    text = (tmp_path / "b.md").read_text()
    head, ideal = text.split("## Ideal sensor rows")
    assert "`a_real`" in head and "`b_ideal`" not in head
    assert "`b_ideal`" in ideal and "| 0.10-0.20 | met |" in head
