"""Contact-microphone signals: materials, rims, shaking, transients, the audio chain."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from fingertip.sim.physics import (
    PAPER_SEVEN,
    AudioChain,
    BoxShake,
    ContactMakeBreak,
    CupStackSlide,
    Idle,
    Slide,
    simulate,
)
from fingertip.sim.physics.vibration import good_fft_size

FS = 44100


def band_features(x: np.ndarray, bands: int = 16) -> np.ndarray:
    """Log energy in log-spaced bands, 100 Hz - 16 kHz (a simple spectral feature)."""
    spec = np.abs(np.fft.rfft(x * np.hanning(len(x)))) ** 2
    f = np.fft.rfftfreq(len(x), 1 / FS)
    edges = np.geomspace(100, 16000, bands + 1)
    e = np.array([spec[(f >= lo) & (f < hi)].sum() for lo, hi in itertools.pairwise(edges)])
    return 10 * np.log10(e + 1e-20)


def band_energy(x: np.ndarray, lo: float, hi: float) -> float:
    spec = np.abs(np.fft.rfft(x.astype(float))) ** 2 / len(x)
    f = np.fft.rfftfreq(len(x), 1 / FS)
    return float(spec[(f >= lo) & (f < hi)].sum())


def centroid(x: np.ndarray) -> float:
    spec = np.abs(np.fft.rfft(x.astype(float))) ** 2
    f = np.fft.rfftfreq(len(x), 1 / FS)
    keep = f > 200
    return float((f[keep] * spec[keep]).sum() / spec[keep].sum())


@pytest.fixture(scope="module")
def material_features() -> dict[str, np.ndarray]:
    return {m: np.array([band_features(simulate(Slide(m, duration=1.0, seed=s), seed=s)
                                       .audio.samples) for s in range(3)])
            for m in PAPER_SEVEN}


def test_materials_differ_and_copper_tape_and_wax_paper_are_closest(material_features):
    mean = {m: f.mean(axis=0) for m, f in material_features.items()}
    within = max(np.linalg.norm(f - mean[m], axis=1).mean() for m, f in material_features.items())
    pairs = {(a, b): float(np.linalg.norm(mean[a] - mean[b]))
             for a, b in itertools.combinations(PAPER_SEVEN, 2)}
    closest = min(pairs, key=pairs.get)
    assert set(closest) == {"copper_tape", "wax_paper"}
    # Every pair is told apart by more than a recording's own scatter, the close pair too.
    assert min(pairs.values()) > 1.2 * within
    others = sorted(d for p, d in pairs.items() if p != closest)
    assert others[0] > 1.2 * pairs[closest]


def test_speed_moves_the_spectrum_up_and_force_scales_the_amplitude():
    slow = simulate(Slide("textured_fabric", speed_mm_s=10, duration=1.0, seed=1), hum=False)
    fast = simulate(Slide("textured_fabric", speed_mm_s=40, duration=1.0, seed=1), hum=False)
    assert centroid(fast.audio.samples) > 1.5 * centroid(slow.audio.samples)
    light = simulate(Slide("coarse_fabric", normal_n=0.5, seed=2), hum=False).audio.samples
    heavy = simulate(Slide("coarse_fabric", normal_n=2.0, seed=2), hum=False).audio.samples
    assert heavy.std() > 2 * light.std()


def detect_onsets(x: np.ndarray, threshold: float, gap_s: float = 0.2) -> np.ndarray:
    """Threshold the 2 ms rms, cluster above-threshold samples closer than ``gap_s``."""
    win = int(0.002 * FS)
    e = np.sqrt(np.convolve(x.astype(float) ** 2, np.ones(win) / win, "same"))
    idx = np.flatnonzero(e > threshold)
    if not len(idx):
        return np.zeros(0)
    gaps = np.flatnonzero(np.diff(idx) > gap_s * FS)
    return np.concatenate([[idx[0]], idx[gaps + 1]]) / FS


@pytest.mark.parametrize("speed", [7.0, 10.0, 20.0])
def test_cup_rims_give_impulses_at_the_expected_times(speed):
    scene = CupStackSlide(speed_mm_s=speed, seed=int(speed))
    ev = scene.events()
    assert ev["rims_passed"] == 3                          # 21 mm over three of five cups
    expected = scene.pre_s + np.array(ev["rim_offsets_mm"][:3]) / speed
    np.testing.assert_allclose(ev["rim_times_s"], expected)
    np.testing.assert_allclose(np.diff(ev["rim_z_mm"]), -7.0, atol=1.5)
    onsets = detect_onsets(simulate(scene, seed=1).audio.samples, 0.03)
    assert len(onsets) == 3
    np.testing.assert_allclose(onsets, ev["rim_times_s"], atol=0.005)


def test_contact_make_and_break_transients():
    scene = ContactMakeBreak(repeats=2)
    r = simulate(scene, seed=2)
    onsets = detect_onsets(r.audio.samples, 0.01, gap_s=0.05)
    ev = scene.events()
    truth = np.sort(ev["contact_make_s"] + ev["contact_break_s"])
    np.testing.assert_allclose(onsets, truth, atol=0.005)
    f = np.hypot(r.force.fx, r.force.fy)
    assert f.max() == pytest.approx(1.5, rel=0.05)


@pytest.fixture(scope="module")
def shakes() -> dict[str, np.ndarray]:
    return {c: simulate(BoxShake(c, seed=4), seed=4).audio.samples
            for c in ("screws", "rubber_bands", "empty")}


def test_shaking_screws_rings_rubber_bands_thud_empty_is_near_silent(shakes):
    hf = {c: band_energy(x, 2000, 20000) for c, x in shakes.items()}
    assert hf["screws"] > 100 * hf["rubber_bands"]
    lf = {c: band_energy(x, 80, 1000) for c, x in shakes.items()}
    assert lf["rubber_bands"] > 3 * lf["empty"]
    floor = simulate(Idle(5.6), seed=4).audio.samples.std()
    assert shakes["empty"].std() < 1.5 * floor
    assert shakes["rubber_bands"].std() > shakes["empty"].std()
    scene = BoxShake("screws", seed=4)
    ev = scene.events()
    assert len(ev["turnaround_times_s"]) == 8              # 0.67 Hz over 5.6 s
    assert scene.duration_s == 5.6
    assert scene.position_m(0.25 / 0.67) == pytest.approx(0.05)


def test_clipping_when_the_preamp_gain_is_too_high():
    scene = BoxShake("screws", seed=1)
    normal = simulate(scene, seed=1)
    assert normal.audio.clipped_fraction == 0.0
    loud = simulate(scene, seed=1, preamp_gain=2000.0)
    assert loud.audio.clipped_fraction > 1e-3 and loud.audio.rail_clipped > 0
    assert loud.audio.samples.max() == np.float32(1 - 2 ** -15)
    assert loud.audio.samples.min() == -1.0


@pytest.mark.parametrize("mains", [50.0, 60.0])
def test_mains_hum_appears_only_when_enabled(mains):
    def peak_db(x, f0):
        spec = np.abs(np.fft.rfft(x.astype(float) * np.hanning(len(x))))
        f = np.fft.rfftfreq(len(x), 1 / FS)
        at = spec[np.argmin(np.abs(f - f0))]
        return 20 * np.log10(at / np.median(spec[(f > 20) & (f < 400)]))

    on = simulate(Idle(1.0), seed=1, mains_hz=mains).audio.samples
    off = simulate(Idle(1.0), seed=1, mains_hz=mains, hum=False).audio.samples
    assert peak_db(on, mains) > 30 and peak_db(on, 3 * mains) > 20
    assert peak_db(off, mains) < 15


def test_noise_floor_and_normalisation():
    chain = AudioChain(hum=False)
    x = simulate(Idle(2.0), seed=3, chain=chain).audio.samples
    assert x.dtype == np.float32
    assert x.std() == pytest.approx(chain.noise_floor_rms(), rel=0.1)
    assert 20 * np.log10(x.std()) < -80                    # about -85 dBFS
    lsb = 2.0 ** -15
    np.testing.assert_array_equal(np.rint(x / lsb) * lsb, x)  # 16-bit sound card


def test_audio_is_seeded():
    a = simulate(Slide("tpu", seed=5), seed=1).audio.samples
    b = simulate(Slide("tpu", seed=5), seed=1).audio.samples
    c = simulate(Slide("tpu", seed=6), seed=1).audio.samples
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    assert len(a) == round(0.8 * FS)


def test_fft_sizes():
    for n in (1, 7, 1000, 44100, 123457):
        m = good_fft_size(n)
        assert m >= n and m < 1.3 * n + 2
        while m % 2 == 0:
            m //= 2
        while m % 3 == 0:
            m //= 3
        while m % 5 == 0:
            m //= 5
        assert m == 1
