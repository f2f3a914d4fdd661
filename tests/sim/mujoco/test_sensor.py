"""The fingertip as a MuJoCo sensor: attach, forces and their signs, the hard cases."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest
from scipy.signal import welch

from fingertip.sim.mujoco import FingertipSensor, attach_fingertip, geometry
from fingertip.sim.mujoco.drive import press_and_slide, run
from fingertip.sim.mujoco.scenes import EDGE_DOWN, NAIL_DOWN, probe
from fingertip.sim.mujoco.sensor import DEBOUNCE_S, REFLEX_AUDIO
from fingertip.hardware import load
from fingertip.sim.physics import Realism, VirtualStrainSensor


def _spec() -> mujoco.MjSpec:
    return mujoco.MjSpec.from_string(
        '<mujoco><worldbody><body name="finger"><joint type="free"/>'
        '<geom type="box" size=".01 .01 .02"/></body></worldbody></mujoco>')


def test_attach_builds_the_cad_dimensions_with_mass_and_sensors():
    spec = _spec()
    tip = attach_fingertip(spec, "finger", "tip", pos=(0, 0, 0.02))
    m = spec.compile()
    p = load()
    g = geometry(p)
    assert g.top_z == pytest.approx((p.geometry.base_height_mm + p.geometry.nail_tip_z_mm
                                     + p.geometry.skin_mm) * 1e-3)
    assert g.nail_x[1] - g.half_width == pytest.approx(p.geometry.nail_proud_mm * 1e-3)
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "tip")
    assert 0.003 < m.body_mass[body] < 0.02  # a few grams of PLA, TPU and silicone
    for name in tip.geoms:
        assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, name) >= 0
    assert m.nsensor == 2


def test_attach_refuses_unknown_body_and_duplicate_name():
    spec = _spec()
    with pytest.raises(ValueError, match="no body 'hand'.*finger"):
        attach_fingertip(spec, "hand")
    attach_fingertip(spec, "finger", "tip")
    with pytest.raises(ValueError, match="already has a body named 'tip'"):
        attach_fingertip(spec, "finger", "tip")


def test_fidelity_and_material_names_are_checked():
    sc = probe(("tpu",))
    with pytest.raises(ValueError, match="fidelity must be one of wrench, strain, full"):
        FingertipSensor(sc.model, sc.data, sc.tips["tip"], fidelity="audio")
    with pytest.raises(ValueError, match="no geom 'wood'"):
        FingertipSensor(sc.model, sc.data, sc.tips["tip"], materials={"wood": "tpu"})


def _contact_force_on_tip(m, d, tip_body: int) -> np.ndarray:
    """Independent check: mj_contactForce over every contact, in the global frame."""
    total = np.zeros(3)
    f6 = np.zeros(6)
    for i in range(d.ncon):
        c = d.contact[i]
        b = m.geom_bodyid[c.geom]
        if tip_body not in b:
            continue
        mujoco.mj_contactForce(m, d, i, f6)
        world = c.frame.reshape(3, 3).T @ f6[:3]  # on geom[1] from geom[0]
        total += world if b[1] == tip_body else -world
    return total


def test_press_reads_the_servo_force_with_the_right_sign():
    sc = probe(("tpu",))
    s = FingertipSensor(sc.model, sc.data, sc.tips["tip"], fidelity="wrench",
                        realism=Realism().without("skin"))
    skin = FingertipSensor(sc.model, sc.data, sc.tips["tip"], fidelity="wrench")
    run(sc.model, sc.data, [s, skin], 1.0, press_and_slide(press_m=0.002, slide_mm_s=0.0))
    force, height = s.wrench()
    body = s.reader.body
    direct = _contact_force_on_tip(sc.model, sc.data, body)
    np.testing.assert_allclose(s.reader.force_on_tip(), direct, atol=1e-6)
    # Cap down: the plate pushes the cap towards the prism root (-z of the fingertip),
    # with the servo's 500 N/m x 2 mm.
    assert force[2] == pytest.approx(-1.0, rel=0.05)
    assert abs(force[0]) < 1e-3 and abs(force[1]) < 1e-3
    # On the roof: above the nail tip by about the skin's thickness.
    assert -1.6 < height < -1.3
    last = s.readings()[-1]
    np.testing.assert_allclose(last.force_n, force, atol=0.02)
    # The silicone relaxes under the held load (realism.toml [skin]: 13 % over tens of s).
    relaxed_reading = skin.readings()[-1]
    np.testing.assert_array_equal(relaxed_reading.force_n, last.force_n)  # MuJoCo's force
    relaxed = relaxed_reading.cap_force_n[2] / last.force_n[2]
    assert 0.9 < relaxed < 0.99


def test_slide_friction_opposes_the_motion_and_bends_the_gauges():
    sc = probe(("tpu",))
    s = FingertipSensor(sc.model, sc.data, sc.tips["tip"], fidelity="strain",
                        realism=Realism.none())
    run(sc.model, sc.data, [s], 2.0, press_and_slide(slide_mm_s=20.0))
    rs = s.readings()
    hold = np.array([r.counts for r in rs if 0.7 < r.t < 0.95])
    slide = [r for r in rs if 1.5 < r.t < 2.0]
    fx = np.mean([r.force_n[0] for r in slide])
    assert fx < -0.5  # the probe moves +x, friction pushes the cap -x
    counts = np.array([r.counts for r in slide]).mean(0) - hold.mean(0)
    # -x force: channel 2's face (-x normal) is stretched... the +x face compressed.
    assert counts[0] * counts[2] < 0 and abs(counts[0] - counts[2]) > 1e4
    assert abs(counts[1] - counts[3]) < 0.05 * abs(counts[0] - counts[2])


@pytest.mark.parametrize(("quat", "lo", "hi", "nail"),
                         [(NAIL_DOWN, 0.0, 3.0, True), (EDGE_DOWN, -1.6, 0.5, False)])
def test_nail_and_cap_edge_contacts(quat, lo, hi, nail):
    sc = probe(("tpu",), quat=quat)
    s = FingertipSensor(sc.model, sc.data, sc.tips["tip"], fidelity="full",
                        realism=Realism.none())
    run(sc.model, sc.data, [s], 1.0, press_and_slide(slide_mm_s=10.0, axis=1))
    touches, wrenches = [], []
    control = press_and_slide(slide_mm_s=10.0, axis=1)
    while sc.data.time < 1.5:  # a sliding contact flickers: look at every step
        control(sc.data.time, sc.data)
        mujoco.mj_step(sc.model, sc.data)
        s.step()
        if s.reader.touching:
            touches.append(s.reader.touch())
            wrenches.append(s.wrench())
    assert len(touches) > 0.5 * 0.5 / sc.model.opt.timestep
    assert all(t.nail is nail for t in touches if t.found)
    heights = np.array([h for _, h in wrenches])
    assert lo <= np.median(heights) <= hi
    assert np.median([np.linalg.norm(f) for f, _ in wrenches]) > 0.5
    s.flush()
    rs = s.readings()
    assert all(np.all(np.isfinite(r.raw)) for r in rs)
    audio = np.concatenate([b.samples for b in s.audio()])
    assert np.all(np.isfinite(audio)) and np.abs(audio).max() > 0


def test_deep_penetration_stays_finite_and_saturates():
    sc = probe(("tpu",), kp=2e4)
    s = FingertipSensor(sc.model, sc.data, sc.tips["tip"], fidelity="full",
                        realism=Realism.none())
    run(sc.model, sc.data, [s], 1.0, press_and_slide(press_m=0.015, slide_mm_s=50.0,
                                                     t_slide=0.6))
    touch = s.reader.touch()
    assert touch.depth_m > 0.001 and touch.normal_n > 100  # most of the skin, 50x the range
    rs = s.readings()
    hx = load().hx711
    counts = np.array([r.counts for r in rs])
    assert np.all(np.isfinite([r.raw for r in rs]))
    assert counts.min() >= hx.count_min and counts.max() <= hx.count_max
    assert (counts == hx.count_min).any() or (counts == hx.count_max).any()
    audio = np.concatenate([b.samples for b in s.audio()])
    assert np.all(np.isfinite(audio)) and audio.max() < 1.0 and audio.min() >= -1.0


def test_zero_slip_is_silent_after_the_touch():
    sc = probe(("coarse_fabric",))
    s = FingertipSensor(sc.model, sc.data, sc.tips["tip"], fidelity="full",
                        realism=Realism.none(), materials=sc.materials)
    run(sc.model, sc.data, [s], 2.0, press_and_slide(slide_mm_s=0.0))
    assert s.reader.touch().slip_mm_s < 1.0
    blocks = s.audio()
    late = np.concatenate([b.samples for b in blocks if b.t0 > 1.0])
    early = np.concatenate([b.samples for b in blocks if b.t0 < 1.0])
    assert np.abs(early).max() > 0  # the touch's transient
    assert np.all(late == 0)  # no noise sources, no slip: nothing


def test_the_texture_feels_the_time_averaged_force_through_a_sliding_contacts_flicker():
    # MuJoCo separates the sliding nail from the plate for a step or two, about one step in
    # five; the steps in contact then carry more than the load. The piezo must feel the load.
    sc = probe(("tpu",), quat=NAIL_DOWN)
    s = FingertipSensor(sc.model, sc.data, sc.tips["tip"], fidelity="full",
                        materials=sc.materials)
    pushed, touching, every = [], [], []
    push = s.piezo.push

    def record(t, slip, normal, mat, nail):
        if t > 1.2:
            pushed.append(normal)
            f = s.reader.net_force @ s.reader.near_normal if s.reader.touching else 0.0
            every.append(abs(f))
            if s.reader.touching:
                touching.append(abs(f))
        push(t, slip, normal, mat, nail)

    s.piezo.push = record
    run(sc.model, sc.data, [s], 2.2, press_and_slide(press_m=0.002, slide_mm_s=20.0,
                                                      t_press=0.6, t_slide=1.0, axis=1))
    assert len(touching) < 0.95 * len(every)                 # it does flicker
    assert np.mean(touching) > 1.1 * np.mean(every)          # so the touching steps carry more
    assert np.mean(pushed) == pytest.approx(np.mean(every), rel=0.05)   # the load: 1.0 N
    assert np.mean(pushed) == pytest.approx(1.0, rel=0.1)


def test_conversions_follow_the_hx711_clock_not_the_physics_step():
    for dt in (0.0005, 0.0015):
        sc = probe(("tpu",), timestep=dt)
        s = FingertipSensor(sc.model, sc.data, sc.tips["tip"], fidelity="wrench", rate_sps=80)
        run(sc.model, sc.data, [s], 0.5)
        t = np.array([r.t for r in s.readings()])
        np.testing.assert_allclose(np.diff(t), 1 / 80, atol=1e-9)
        assert len(t) == 40


def test_an_hour_without_contact_stays_at_tare_or_drifts_as_the_realism_model():
    # Error sources off: not one count of drift over an hour of simulated time.
    sc = probe(("tpu",), timestep=0.01)  # nothing touches: a long step is stable
    off = FingertipSensor(sc.model, sc.data, sc.tips["tip"], fidelity="strain",
                          realism=Realism.none(), batch=4096,
                          seed=7)
    on = FingertipSensor(sc.model, sc.data, sc.tips["tip"], fidelity="strain", batch=4096,
                         seed=7)
    run(sc.model, sc.data, [off, on], 3600.0)
    a = np.array([r.counts for r in off.readings()])
    assert len(a) == 3600 * 80
    assert np.all(a == a[0])
    # With every source on, exactly what the virtual fingertip itself reads at zero force.
    rs = on.readings()
    t = np.array([r.t for r in rs])
    ref = VirtualStrainSensor(7).counts_batch(np.zeros((len(t), 2)), 0.0, t, 0.0)
    np.testing.assert_array_equal(np.array([r.counts for r in rs]), ref)
    assert np.ptp(ref[:, 0]) > 0  # and that does drift (temperature, noise)


def _slide_at(dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    sc = probe(("coarse_fabric",), timestep=dt)
    s = FingertipSensor(sc.model, sc.data, sc.tips["tip"], fidelity="full",
                        realism=Realism.ideal(), materials=sc.materials, seed=3)
    run(sc.model, sc.data, [s], 2.5, press_and_slide(slide_mm_s=20.0))
    rs = s.readings()
    hold = np.array([r.counts for r in rs if 0.7 < r.t < 0.95])
    slide = np.array([r.counts for r in rs if 1.5 < r.t < 2.5])
    audio = np.concatenate([b.samples for b in s.audio() if b.t0 > 1.5])
    freqs, psd = welch(audio, 44100, nperseg=2048)
    bands = [(100, 500), (500, 1000), (1000, 2000), (2000, 4000), (4000, 8000)]
    energy = np.array([10 * np.log10(psd[(freqs >= lo) & (freqs < hi)].sum())
                       for lo, hi in bands])
    return hold, slide, energy, s.strain.noise_counts_rms()


def test_the_physics_step_changes_neither_counts_nor_audio_bands():
    hold0, slide0, energy0, noise = _slide_at(0.0005)
    for dt in (0.001, 0.002):
        hold, slide, energy, _ = _slide_at(dt)
        # Held: the same counts within the HX711's noise.
        assert np.all(np.abs(hold.mean(0) - hold0.mean(0)) < 2 * noise)
        # Sliding: within the counts' own scatter. MuJoCo's servoed probe stick-slips more at
        # longer steps (the force's scatter grows 0.05 -> 0.15 N from 0.5 to 2 ms), the mean
        # force stays within 1 %.
        scatter = np.sqrt((slide0.std(0) ** 2 + slide.std(0) ** 2) / 2)
        assert np.all(np.abs(slide.mean(0) - slide0.mean(0)) < scatter)
        # The audio's band energies within 2 dB.
        np.testing.assert_array_less(np.abs(energy - energy0), 2.0)


def test_reflex_audio_comes_within_a_block_of_the_sound_and_sounds_the_same():
    # A reflex hears the piezo as soon as a low-latency capture would deliver it; the
    # defaults render DEBOUNCE_S behind the physics in long blocks. Same sound either way.
    sc = probe(("tpu",))
    kw = dict(fidelity="full", realism=Realism.none(), materials=sc.materials)
    streams = {"default": FingertipSensor(sc.model, sc.data, sc.tips["tip"], **kw),
               "reflex": FingertipSensor(sc.model, sc.data, sc.tips["tip"], **kw,
                                         **REFLEX_AUDIO)}
    with pytest.raises(ValueError, match="audio_lag_s"):
        FingertipSensor(sc.model, sc.data, sc.tips["tip"], **kw, audio_lag_s=-0.01)
    control = press_and_slide(t_press=0.3, t_slide=0.6)
    audio = {k: [] for k in streams}
    heard: dict[str, tuple[float, float]] = {}   # (time of the touch's first sound, sim time)
    d = sc.data
    while d.time < 1.0:
        control(d.time, d)
        mujoco.mj_step(sc.model, d)
        for k, s in streams.items():
            s.step()
            for b in s.audio():
                audio[k].append(b.samples)
                loud = np.flatnonzero(np.abs(b.samples) > 1e-4)
                if k not in heard and loud.size:
                    heard[k] = (b.t0 + loud[0] / b.fs, d.time)
    (t_fast, at_fast), (t_slow, at_slow) = heard["reflex"], heard["default"]
    assert t_fast == pytest.approx(t_slow, abs=1e-4)               # the touch, at 0.3 s
    block_s = REFLEX_AUDIO["audio_block"] / 44100
    assert at_fast - t_fast <= block_s + sc.model.opt.timestep     # 11.6 ms at most
    assert at_slow - t_slow >= DEBOUNCE_S                          # 20 ms and more
    fast, slow = (np.concatenate(audio[k]) for k in ("reflex", "default"))
    n = min(len(fast), len(slow))
    # Identical up to the slide; then MuJoCo lets the sliding nail hop, and a hop longer
    # than DEBOUNCE_S is a release whose click the reflex stream can only place late.
    press = int(0.6 * 44100)
    assert n > press + 0.2 * 44100
    np.testing.assert_allclose(fast[:press], slow[:press], atol=1e-6)
    rms = [float(np.sqrt(np.mean(x[press:n] ** 2))) for x in (fast, slow)]
    assert rms[0] == pytest.approx(rms[1], rel=0.1)
