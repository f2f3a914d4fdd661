"""Scenes compute only what they need; simulate's time bases; the calibration sweep; cost."""
from __future__ import annotations

import numpy as np
import pytest

from fingertip.sim.physics import (
    BoxShake,
    CupStackSlide,
    CustomForce,
    Idle,
    Press,
    Realism,
    Script,
    Slide,
    VirtualStrainSensor,
    simulate,
    strain,
    vibration,
)
from fingertip.sim.device.calibration_rig import COLUMNS, calibration_sweep


@pytest.fixture
def calls(monkeypatch):
    """Count the calls into the strain chain and the vibration synthesis."""
    counts = {"force": 0, "vibration": 0}
    render, batch = vibration.render, strain.VirtualStrainSensor.simulate_batch

    def counted_render(*a, **k):
        counts["vibration"] += 1
        return render(*a, **k)

    def counted_batch(self, *a, **k):
        counts["force"] += 1
        return batch(self, *a, **k)

    monkeypatch.setattr(vibration, "render", counted_render)
    monkeypatch.setattr(strain.VirtualStrainSensor, "simulate_batch", counted_batch)
    return counts


def test_a_force_scene_never_runs_the_vibration_synthesis(calls, monkeypatch):
    def boom(*a, **k):
        raise AssertionError("vibration synthesised for a force-only scene")

    monkeypatch.setattr(vibration, "slide_excitation", boom)
    monkeypatch.setattr(Press, "excitation", boom)
    r = simulate(Press())
    assert calls == {"force": 1, "vibration": 0}
    assert r.audio is None and r.force is not None and set(r.wall_s) == {"force"}


def test_a_vibration_scene_never_runs_the_strain_model(calls, monkeypatch):
    def boom(*a, **k):
        raise AssertionError("forces computed for a vibration-only scene")

    monkeypatch.setattr(BoxShake, "forces", boom)
    monkeypatch.setattr(CupStackSlide, "forces", boom)
    for scene in (BoxShake("empty"), CupStackSlide(), Slide("wax_paper")):
        r = simulate(scene)
        assert r.force is None and r.audio is not None
    assert calls == {"force": 0, "vibration": 3}


def test_signals_override_and_scripts_take_the_union(calls):
    both = Slide("tpu", signals=("force", "vibration"))
    r = simulate(both)
    assert r.force is not None and r.audio is not None
    assert r.force.fz.max() == pytest.approx(0.9)         # friction of TPU at 1 N
    assert calls == {"force": 1, "vibration": 1}
    with pytest.raises(ValueError):
        _ = Press(signals=("smell",)).needs
    script = Script((Press(peak_n=2.0), Slide("coarse_fabric")), gap_s=0.5)
    assert script.needs == {"force", "vibration"}
    r = simulate(script)
    assert calls == {"force": 2, "vibration": 2}
    parts = r.events["parts"]
    assert parts[1]["start_s"] == pytest.approx(Press().duration_s + 0.5)
    assert parts[1]["events"]["slide_start_s"] == pytest.approx(parts[1]["start_s"])
    # The press contributes force only; the slide contributes audio only.
    t = r.force.t_us * 1e-6
    assert np.hypot(r.force.fx, r.force.fy)[t > parts[1]["start_s"]].max() == 0.0
    press_audio = r.audio.samples[: int(parts[0]["end_s"] * 44100)]
    slide_audio = r.audio.samples[int(parts[1]["start_s"] * 44100):]
    assert slide_audio.std() > 3 * press_audio.std()


def test_time_bases():
    r = simulate(Idle(1.0), t0_us=5_000_000, rate_sps=10)
    np.testing.assert_array_equal(r.force.t_us, 5_000_000 + 100_000 * np.arange(1, 11))
    assert r.force.counts.shape == (10, 4) and r.force.counts.dtype == np.int64
    assert len(r.audio.samples) == 44100 and r.audio.index[-1] == 44099
    assert r.audio.t_us[44100 // 2] == pytest.approx(5_500_000)
    assert r.realtime_factor > 0


def test_custom_force_and_a_shared_sensor_keep_state():
    sensor = VirtualStrainSensor(2, rate_sps=80)
    ramp = CustomForce(lambda t: (2.0 * t, 0 * t, 1.0), duration=1.0)
    a = simulate(ramp, sensor=sensor)
    b = simulate(Idle(1.0, signals=("force",)), sensor=sensor, t0_us=1_000_000)
    assert a.force.fx[-1] == pytest.approx(2.0)
    # Hysteresis and creep carried over: unloaded, the reading is not yet back at zero.
    fresh = simulate(Idle(1.0, signals=("force",)), sensor=VirtualStrainSensor(2))
    assert abs(b.force.counts[:, 2].mean() - fresh.force.counts[:, 2].mean()) > 500


def test_calibration_sweep_follows_the_paper():
    sw = calibration_sweep(seed=1, realism=Realism.none())
    assert len(sw) == 11 * 6 * 40                         # angles x heights x (20 in + 20 out)
    assert sorted(set(sw.angle_deg)) == list(range(-50, 51, 10))
    assert sorted(set(sw.height_mm)) == [0, 1, 2, 3, 4, 5]
    assert sw.displacement_mm.max() == 30.0 and set(np.diff(np.unique(sw.displacement_mm))) \
        == {1.5}
    f = np.hypot(sw.fx, sw.fy)
    assert 4.4 < f.max() <= 5.0 and f[~sw.loading & (sw.displacement_mm == 0)].max() == 0
    np.testing.assert_allclose(np.degrees(np.arctan2(sw.fy, sw.fx))[f > 0], sw.angle_deg[f > 0])
    rows = sw.rows()
    assert rows.shape == (len(sw), len(COLUMNS)) == (2640, 8)
    assert np.all(np.diff(sw.t_us) > 8_000_000)           # an 8 s pause before each reading
    # Randomised order: the trials do not run angle by angle.
    first = sw.angle_deg[sw.step == 0][:6]
    assert len(set(first)) > 1
    two = calibration_sweep(seed=1, samples_per_step=3, angles_deg=(0,), heights_mm=(0,))
    assert len(two) == 120
