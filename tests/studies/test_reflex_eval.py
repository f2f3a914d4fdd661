"""The reflex study (studies/reflex_eval.py) on a small set of simulated touches."""
from __future__ import annotations

from fingertip.sim.physics.touch import render_session, touch_sessions
from studies.reflex_eval import run_session, summarise


def test_small_evaluation_fused_beats_force_and_misses_nothing():
    """20 simulated touches (seeds 7..10): the bench runs 500 (tests/bench/bench_reflex.py)."""
    sessions = touch_sessions(20, 5, 7, speech_db=65.0)
    fused, f80 = [], []
    for s in sessions:
        audio = render_session(s)
        fused.append(run_session(s, "fused", 80, audio=audio, wall_clock=False))
        f80.append(run_session(s, "force", 80, wall_clock=False))
    a, b = summarise(fused), summarise(f80)
    assert a["contacts"] == 20 and a["missed"] == 0 and b["missed"] == 0
    assert a["p99_ms"] < 5.0 < b["p50_ms"]
    assert a["false"] == 0
