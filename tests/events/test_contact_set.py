"""A hand's contact detectors (one per finger) on the hard cases, fed as a recipe feeds them:
64-sample audio blocks per finger, force frames at 80 Hz."""
from __future__ import annotations

import numpy as np
import pytest

from fingertip.events.contact_set import ContactSet
from fingertip.sim.physics import AudioChain, Excitation
from fingertip.sim.physics.disturbances import motor_noise
from fingertip.sim.physics.vibration import half_sine, place

FS = 44100
N = FS // 2


def _audio(t: float, amp: float, seed: int, gain=None, motor: float = 0.0) -> np.ndarray:
    f = place(N, np.array([t]), np.array([amp]), half_sine(3e-4, FS), FS)
    if motor:
        f = f + motor_noise(N, FS, np.random.default_rng(seed), motor)
    chain = AudioChain(preamp_gain=gain)
    return chain.finish(chain.filter([Excitation(f)], N), 0, np.random.default_rng(seed)).samples


def _feed(cs: ContactSet, audio: dict[str, np.ndarray], touch: dict[str, float]):
    """Blocks of 64 samples, a force frame every 12.5 ms (0.2 N/frame ramps from each
    finger's touch)."""
    events = []
    next_frame = 1 / 80
    for a in range(0, N, 64):
        t_end = (a + 64) / FS
        if t_end >= next_frame:
            for f, tc in touch.items():
                events += cs.feed_force(f, next_frame, max(0.0, next_frame - tc) * 16.0)
            next_frame += 1 / 80
        for f, x in audio.items():
            events += cs.feed_audio(f, x[a:a + 64], a / FS)
    return events


def test_two_fingers_20_ms_apart_one_moving_fast_one_saturated_each_on_time():
    touch = {"f0": 0.25, "f1": 0.27}
    audio = {"f0": _audio(0.25, 0.08, 1, motor=3.0),            # joint at 3 rad/s
             "f1": _audio(0.27, 1.0, 2, gain=2000.0)}           # clips the sound card
    assert np.mean(np.abs(audio["f1"]) > 0.99) > 0
    cs = ContactSet(["f0", "f1"], "fused", fs=FS)
    ev = _feed(cs, audio, touch)
    for f, tc in touch.items():
        mine = [e for g, e in ev if g == f]
        kinds = [e.kind for e in mine]
        assert kinds[:2] == ["contact", "contact_confirmed"], (f, kinds)
        assert mine[0].source == "piezo"
        assert mine[0].time == pytest.approx(tc, abs=6e-4)
        assert mine[0].latency_s < 64 / FS + 6e-4          # known within its block
        assert "contact_retracted" not in kinds


def test_force_only_set_waits_for_the_frames():
    touch = {"f0": 0.25, "f1": 0.27}
    cs = ContactSet(["f0", "f1"], "force")
    ev = _feed(cs, {}, touch)
    first = {f: next(e for g, e in ev if g == f and e.kind == "contact") for f in touch}
    for f, tc in touch.items():
        assert first[f].source == "force"
        assert tc < first[f].time <= tc + 2 / 80 + 1e-9      # the next frame or the one after
