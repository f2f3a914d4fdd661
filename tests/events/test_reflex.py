"""Contact reflexes: the piezo onset, force and fused detectors on hard cases."""
from __future__ import annotations

import json

import numpy as np
import pytest

from fingertip.events.reflex import (
    ForceContact,
    FusedConfig,
    FusedContact,
    OnsetDetector,
    RecorderSink,
    ReflexEvent,
)
from fingertip.sim.physics import AudioChain, Excitation
from fingertip.sim.physics.disturbances import motor_noise
from fingertip.sim.physics.touch import Session, Touch
from fingertip.sim.physics.vibration import half_sine, place

FS = 44100


def piezo(times, amps, n=FS // 2, pulse_s=3e-4, gain=None, extra=None, seed=0):
    """Sound-card samples of make transients at ``times`` (nail force pulses), plus an
    ``extra`` nail force."""
    f = place(n, np.asarray(times, float), np.asarray(amps, float), half_sine(pulse_s, FS), FS)
    if extra is not None:
        f = f + extra
    chain = AudioChain(preamp_gain=gain)
    rng = np.random.default_rng(seed)
    return chain.finish(chain.filter([Excitation(f)], n), 0, rng).samples


def test_onsets_do_not_depend_on_block_size():
    x = piezo([0.1, 0.23, 0.4], [0.05, 0.02, 0.1],
              extra=motor_noise(FS // 2, FS, np.random.default_rng(1), 0.5))
    whole = OnsetDetector(FS).feed(x, 0.0)
    assert len(whole) == 3
    for sizes in ([64], [1, 7, 500, 3], [4410]):
        d = OnsetDetector(FS)
        got, a, k = [], 0, 0
        while a < len(x):
            b = min(len(x), a + sizes[k % len(sizes)])
            got += d.feed(x[a:b], a / FS)
            a, k = b, k + 1
        assert [round(t, 9) for t, _ in got] == [round(t, 9) for t, _ in whole]


def test_two_contacts_20_ms_apart_are_two_onsets_each_on_time():
    x = piezo([0.2, 0.22], [0.04, 0.04])
    on = OnsetDetector(FS).feed(x, 0.0)
    assert [round(t, 3) for t, _ in on] == pytest.approx([0.2, 0.22], abs=6e-4)


def test_contact_during_fast_motion_is_heard_but_the_motor_is_not():
    n = FS
    motor = motor_noise(n, FS, np.random.default_rng(2), 3.0)   # joint at 3 rad/s
    x = piezo([0.6], [0.004 * 20], n=n, extra=motor)             # a 20 mm/s touch
    on = OnsetDetector(FS).feed(x, 0.0)
    assert len(on) == 1 and on[0][0] == pytest.approx(0.6, abs=6e-4)
    # The same motor noise alone: nothing.
    assert OnsetDetector(FS).feed(piezo([], [], n=n, extra=motor), 0.0) == []


def test_motor_start_fires_unless_the_hand_gates_it():
    n = FS
    speed = np.clip((np.arange(n) / FS - 0.3) / 0.03, 0, 1) * 2.0   # starts at 0.3 s
    x = piezo([], [], n=n, extra=motor_noise(n, FS, np.random.default_rng(3), speed))
    assert OnsetDetector(FS).feed(x, 0.0)
    d = OnsetDetector(FS)
    d.gate(0.3, 0.38)
    assert d.feed(x, 0.0) == []
    assert d.gated > 0


def test_saturated_piezo_gives_one_onset_on_time_and_recovers():
    x = piezo([0.2, 0.4], [1.0, 0.01], gain=2000.0)
    assert np.mean(np.abs(x) > 0.99) > 0            # clipped at full scale
    on = OnsetDetector(FS).feed(x, 0.0)
    assert [round(t, 3) for t, _ in on] == pytest.approx([0.2, 0.4], abs=6e-4)


def test_silence_and_bad_input():
    d = OnsetDetector(FS)
    assert d.feed(np.zeros(FS), 0.0) == []
    assert d.feed(np.zeros(0), 1.0) == []
    with pytest.raises(ValueError):
        d.feed(np.array([0.0, np.nan]), 1.0)
    with pytest.raises(ValueError):
        OnsetDetector(1000.0)                      # the band does not fit
    with pytest.raises(ValueError):
        d.gate(2.0, 1.0)


def test_force_contact_ignores_drift_and_settles_after_a_release():
    fc = ForceContact()
    t = np.arange(0, 4, 1 / 80)
    drift = 0.02 * t / 4                             # 20 mN over 4 s: creep, temperature
    assert [fc.feed(a, b) for a, b in zip(t, drift, strict=True)].count("make") == 0
    fc = ForceContact()
    f = np.where((t > 1) & (t < 2), 1.0, 0.0) + np.where(t >= 2, 0.06 * np.exp(-(t - 2)), 0)
    changes = [(a, c) for a, b in zip(t, f, strict=True) if (c := fc.feed(a, b))]
    assert [c for _, c in changes] == ["make", "break"]   # the residue is not a new contact
    with pytest.raises(ValueError):
        fc.feed(5.0, float("inf"))


def test_fused_state_machine_and_callbacks():
    got: list[ReflexEvent] = []
    fu = FusedContact(FS, FusedConfig(window_s=0.1), callbacks=[got.append])
    fu.feed_onsets([(1.000, 30.0)], now=1.002)
    fu.feed_force(1.0125, 0.0)
    fu.feed_force(1.025, 0.2)                       # confirms
    fu.feed_onsets([(2.000, 30.0)], now=2.002)       # heard the skin leave ...
    fu.feed_force(2.0125, 0.0)                       # ... and the force agrees
    fu.feed_onsets([(3.000, 30.0)], now=3.002)       # a knock: no force follows
    for k in range(12):
        fu.feed_force(3.0125 + k / 80, 0.0)
    fu.feed_force(4.0, 0.5)                          # too soft to hear: force alone
    kinds = [(e.kind, e.source) for e in got]
    assert kinds == [("contact", "piezo"), ("contact_confirmed", "force"),
                     ("release", "piezo"), ("release_confirmed", "force"),
                     ("contact", "piezo"), ("contact_retracted", "force"),
                     ("contact", "force")]
    assert got[0].latency_s == pytest.approx(0.002)
    assert got[1].time == 1.0 and got[1].latency_s == pytest.approx(0.025)
    assert fu.counts["contact"] == 3


def test_events_reach_a_recording_events_topic(tmp_path):
    from fingertip.record import Recorder, Recording

    path = tmp_path / "reflex.mcap"
    with Recorder(path) as rec:
        sink = RecorderSink(rec, "index")
        fu = FusedContact(FS, callbacks=[sink])
        fu.feed_force(9.9875, 0.0)
        fu.feed_onsets([(10.0, 20.0)], now=10.003)
        fu.feed_force(10.0125, 0.3)
    assert sink.written == 2 and sink.refused == 0
    events = [r for r in Recording(path).records(kinds=("events",))]
    assert [e.msg.kind for e in events] == ["contact", "contact_confirmed"]
    assert all(e.topic == "/fingertip/index/events" for e in events)
    detail = json.loads(events[0].msg.detail)
    assert detail["source"] == "piezo" and detail["latency_ms"] == pytest.approx(3.0)


def test_a_session_gives_its_truth():
    tc = Touch(0.5, 20.0, 1.0, 1.0, hold_s=0.2)
    s = Session(1.5, [tc], 3)
    assert tc.t_release_s == pytest.approx(0.5 + 2 * 0.05 + 0.2)
    t = np.array([0.49, 0.5, 0.525, 0.6, 0.7, 0.8, 0.9])
    np.testing.assert_allclose(s.true_force(t), [0, 0, 0.5, 1, 1, 0, 0], atol=1e-9)
    assert s.motion_starts() == pytest.approx([0.3, 0.75], abs=2e-3)   # approach, unload
    with pytest.raises(ValueError):
        Touch(0.5, 0.0, 1.0, 1.0)
