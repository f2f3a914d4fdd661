"""The simulation's cost study (studies/sim_speed.py) reports every scene."""
from __future__ import annotations

from studies.sim_speed import STANDARD_SCENES, scene_realtime_factors


def test_realtime_factors_are_reported_for_every_scene():
    figures = scene_realtime_factors(repeats=1)
    assert set(figures) == {f"sim_realtime_factor_{k}" for k in STANDARD_SCENES}
    assert all(v > 0 for v in figures.values())
