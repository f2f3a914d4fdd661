"""Event detection on simulated scenes with known ground truth, and on hard inputs."""
from __future__ import annotations

import numpy as np
import pytest

from fingertip.events import Event, contact_intervals, heights_at, refine_contacts, vibration_onsets
from fingertip.sim.physics import CupStackSlide, Press, simulate


def test_cup_rims_are_found_at_their_times():
    scene = CupStackSlide()
    r = simulate(scene, seed=4)
    rims = scene.events()["rim_times_s"]
    onsets = vibration_onsets(r.audio.samples, r.audio.fs)
    got = [e.time for e in onsets]
    assert len(got) == len(rims), (got, rims)
    assert np.max(np.abs(np.array(got) - np.array(rims))) < 0.01


def test_press_contact_make_and_break():
    scene = Press(angle_deg=30, peak_n=2.0, ramp_s=0.5, hold_s=0.5, pre_s=0.5, post_s=0.5)
    r = simulate(scene, seed=2)
    t = r.force.t_us * 1e-6
    ev = contact_intervals(t, r.force.counts)
    kinds = [e.kind for e in ev]
    assert kinds == ["contact_make", "contact_break"]
    truth = scene.events()
    assert abs(ev[0].time - truth["contact_make_s"]) < 0.2
    assert abs(ev[1].time - truth["contact_break_s"]) < 0.2


def test_silence_clipping_and_bad_values():
    assert vibration_onsets(np.zeros(44100), 44100) == []
    clipped = np.clip(np.random.default_rng(0).normal(0, 5, 44100), -1, 1)
    assert len(vibration_onsets(clipped, 44100)) <= 1  # saturated noise is one long burst
    with pytest.raises(ValueError, match="NaN"):
        vibration_onsets(np.array([0.0, np.nan, 0.0]), 44100)
    with pytest.raises(ValueError, match="NaN"):
        contact_intervals(np.arange(3.0), np.array([[0, 0], [np.inf, 0], [0, 0]]))
    assert contact_intervals(np.arange(2.0), np.zeros((2, 4))) == []


def test_rim_heights_from_the_robots_log():
    scene = CupStackSlide(speed_mm_s=7.0)
    r = simulate(scene, seed=5)
    onsets = vibration_onsets(r.audio.samples, r.audio.fs)
    truth = scene.events()
    # The robot's log: z falls at the slide speed from z_start after pre_s.
    t = np.linspace(0, scene.duration_s, 200)
    z = scene.z_mm(t)
    got = [h for _, h in heights_at(onsets, t, z)]
    want = truth["rim_z_mm"][:truth["rims_passed"]]
    assert np.max(np.abs(np.array(got) - np.array(want))) < 0.3  # mm
    with pytest.raises(ValueError, match="outside"):
        heights_at([Event(99.0, "x")], t, z)


def test_contacts_take_the_piezo_time():
    force = [Event(1.010, "contact_make"), Event(2.0, "contact_break")]
    vib = [Event(0.9995, "vibration_onset"), Event(1.5, "vibration_onset")]
    out = refine_contacts(force, vib)
    assert out[0].time == 0.9995 and out[1].time == 2.0
