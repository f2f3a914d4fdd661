"""Shake-and-pick on the simulated hand: two identical boxes, screws and rubber bands."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

import fingertip.tasks as tasks
from fingertip.sim.experiment import BOX_GRIP_Z_MM, run_shake, shake_table
from fingertip.tasks.shake_pick import ShakeConfig, aside, read_box, shake_and_pick
from fingertip.sim.world.boxes import BOX_X_MM, make_box_world

TRIALS = 8
"""Four a material, each pair in random order; `make bench` runs the paper's 56
(`shake_pick_success`, goal 53/56)."""


@pytest.fixture(scope="module")
def clf(shake_clf):
    return shake_clf


def test_shake_and_pick_trials(clf):
    r = run_shake(TRIALS, seed=0)
    s = r.summary()
    assert {m: v["trials"] for m, v in s["per_target"].items()} == {
        "screws": TRIALS // 2, "rubber_bands": TRIALS // 2}
    assert s["success"] >= TRIALS - 1, (s, [t for t in r.trials if t["failure"]])
    assert sum(s["failure_modes"].values()) == TRIALS - s["success"]
    assert s["box_votes"] == 2 * TRIALS
    assert all(b["predictions"] == 46 for t in r.trials for b in t["boxes"])  # 10 Hz
    table = shake_table(r)
    assert "| Metric | Screw-filled box | Rubber-band box |" in table
    assert f"overall: {s['success']}/{TRIALS}" in table


def test_shake_drives_the_box_contents(clf):
    world, hand, arm = make_box_world(3)
    reading = read_box(hand, arm, clf, (BOX_X_MM[0], 0.0, BOX_GRIP_Z_MM), ShakeConfig())
    assert reading.failure is None and reading.predictions == 46
    assert reading.vote == world.boxes[0].content
    (shake,) = world.shakes
    assert shake["box"] == 0 and 0.8 <= shake["grip_n"] / 1.2 <= 1.5
    assert shake["amplitude_mm"] == pytest.approx(50.0 * world.amplitude_gain)
    hand.read()                                                 # one frame: the world moves on
    assert world.held is None and world.opened is None        # put back, not opened


def test_a_hand_without_audio_is_refused_before_anything_moves(clf):
    from fingertip.tasks.interfaces import RobotHand

    world, hand, arm = make_box_world(6)
    start = arm.position()

    class DeafHand(type(hand)):
        read_audio = RobotHand.read_audio

    hand.__class__ = DeafHand
    with pytest.raises(NotImplementedError, match=r"reading a box needs DeafHand\.read_audio"):
        shake_and_pick(hand, arm, clf, [(BOX_X_MM[0], 0.0, BOX_GRIP_Z_MM)], "screws")
    assert arm.position() == start and world.held is None
    assert all(p == 0 for p in hand.positions().values())


def test_no_box_is_a_grasp_failure(clf):
    world, hand, arm = make_box_world(4)
    cfg = ShakeConfig()
    cfg.grip.timeout_s = 2.0
    r = shake_and_pick(hand, arm, clf, [(0.0, 0.0, BOX_GRIP_Z_MM)], "screws", cfg)
    assert r.failure == "grasp failure" and r.chosen is None and world.opened is None
    assert all(p == 0 for p in hand.positions().values())


def test_a_shake_shorter_than_a_window_gives_no_prediction(clf):
    world, hand, arm = make_box_world(5)
    r = shake_and_pick(hand, arm, clf, [(x, 0.0, BOX_GRIP_Z_MM) for x in BOX_X_MM], "screws",
                       ShakeConfig(duration_s=0.5))
    assert r.failure == "no predictions" and world.opened is None


def test_unknown_target_is_refused(clf):
    world, hand, arm = make_box_world(0)
    with pytest.raises(ValueError, match="target"):
        shake_and_pick(hand, arm, clf, [(0.0, 0.0, 0.0)], "marbles")


@pytest.mark.parametrize("module", ["grip", "pinch", "cups", "shake_pick", "interfaces"])
def test_recipes_do_not_import_the_simulation(module):
    """A recipe sees the robot through the interfaces and the sensor streams only."""
    src = Path(tasks.__file__).with_name(f"{module}.py").read_text()
    names = [n.module or "" for n in ast.walk(ast.parse(src)) if isinstance(n, ast.ImportFrom)]
    names += [a.name for n in ast.walk(ast.parse(src)) if isinstance(n, ast.Import)
              for a in n.names]
    assert not [m for m in names if "sim" in m.split(".")], names


def test_stepping_aside_and_opening_lower_run_unchanged_in_this_world(clf):
    # The MuJoCo hand's settings (tasks/shake_pick.py's clear_mm and open_dz_mm): the same
    # recipe, the same result here, the arm's extra moves included.
    cfg = ShakeConfig(clear_mm=(0.0, 7.0), open_dz_mm=-18.0)
    assert aside((-80.0, 0.0, 40.0), cfg) == (-80.0, 7.0, 40.0)
    world, hand, arm = make_box_world(2)
    target = world.boxes[1].content
    r = shake_and_pick(hand, arm, clf, [(x, 0.0, BOX_GRIP_Z_MM) for x in BOX_X_MM], target, cfg)
    assert r.failure is None and r.chosen == 1 and world.opened == 1
    assert arm.position() == (BOX_X_MM[1], 0.0, BOX_GRIP_Z_MM - 18.0)
    assert all(b.predictions == 46 for b in r.readings)
