"""Piezo disturbances: motor noise, taps, speech and room noise, mains hum."""
from __future__ import annotations

import numpy as np
import pytest

from fingertip.sim.physics import AudioChain, Excitation
from fingertip.sim.physics.disturbances import (
    HUM_60,
    MOTOR,
    HumParams,
    MotorNoiseParams,
    TapParams,
    hum_rms_v,
    mains_hum,
    motor_noise,
    robot_taps,
    room_noise,
    speech,
    spl_to_pa,
    tap_times,
)
from fingertip.sim.physics.vibration import half_sine, place

FS = 44100


def rng(seed: int = 0) -> np.random.Generator:
    return np.random.default_rng(seed)


def peak_freq(x: np.ndarray, lo: float = 20.0) -> float:
    spec = np.abs(np.fft.rfft(x * np.hanning(len(x))))
    f = np.fft.rfftfreq(len(x), 1 / FS)
    spec[f < lo] = 0
    return float(f[np.argmax(spec)])


def band_rms(x: np.ndarray, lo: float, hi: float) -> float:
    spec = np.abs(np.fft.rfft(x)) ** 2
    f = np.fft.rfftfreq(len(x), 1 / FS)
    return float(np.sqrt(2 * spec[(f >= lo) & (f < hi)].sum()) / len(x))


def piezo(force: np.ndarray) -> np.ndarray:
    """Sound-card samples of a nail force, without the chain's own noise and hum."""
    chain = AudioChain(noise=False, hum=False)
    n = len(force)
    return chain.finish(chain.filter([Excitation(force)], n), 0, rng(9)).samples.astype(float)


@pytest.mark.parametrize("fn", [motor_noise, speech, room_noise, mains_hum])
def test_empty_and_deterministic(fn):
    assert fn(0, FS, rng()).shape == (0,)
    a, b = fn(4410, FS, rng(3)), fn(4410, FS, rng(3))
    assert a.shape == (4410,) and a.dtype == np.float64
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, fn(4410, FS, rng(4)))


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError):
        motor_noise(-1, FS, rng())
    with pytest.raises(ValueError):
        speech(10, 0, rng())
    with pytest.raises(ValueError):
        motor_noise(10, FS, rng(), np.array([1.0] * 9 + [np.nan]))
    with pytest.raises(ValueError):
        MotorNoiseParams(gear_ratio=0)
    with pytest.raises(ValueError):
        HumParams(harmonics=(1, 2), amplitude_uv_rms=(1.0,))
    with pytest.raises(ValueError):
        TapParams(pulse_s=0)
    with pytest.raises(ValueError):
        tap_times(-1.0, 1.0, rng())


def test_motor_is_silent_when_stopped_and_rises_with_speed():
    n = FS // 2
    assert not motor_noise(n, FS, rng(), 0.0).any()
    assert not motor_noise(n, FS, rng(), MOTOR.min_speed_rad_s / 2).any()
    rms = [motor_noise(n, FS, rng(s), speed).std() for s, speed in enumerate((0.3, 1, 3))]
    assert rms[0] < rms[1] < rms[2]
    # Amplitude proportional to speed (exponent 1), within the noise of one realisation.
    assert rms[2] / rms[1] == pytest.approx(3.0, rel=0.2)
    # The sign of the speed does not matter.
    assert motor_noise(n, FS, rng(), -1.0).std() == pytest.approx(rms[1], rel=0.2)


def test_motor_tones_are_proportional_to_joint_speed():
    params = MotorNoiseParams(broadband_n_rms=0.0, speed_jitter=0.0, mesh_n=0.0)
    for speed in (0.8, 2.0):
        x = motor_noise(FS, FS, rng(), speed, params)
        assert peak_freq(x) == pytest.approx(params.commutation_hz(speed), abs=2.0)
    mesh = MotorNoiseParams(broadband_n_rms=0.0, speed_jitter=0.0, commutation_n=0.0)
    x = motor_noise(FS, FS, rng(), 1.5, mesh)
    assert peak_freq(x) == pytest.approx(mesh.mesh_hz(1.5), abs=2.0)
    f1 = params.commutation_hz(1.0)
    x = motor_noise(FS, FS, rng(), 1.0, params)
    # Harmonic k has 1 / k of the fundamental's amplitude.
    h1, h3 = band_rms(x, f1 - 5, f1 + 5), band_rms(x, 3 * f1 - 5, 3 * f1 + 5)
    assert h3 / h1 == pytest.approx(1 / 3, rel=0.1)


def test_motor_follows_a_speed_profile_and_drops_harmonics_above_nyquist():
    n = FS
    profile = np.where(np.arange(n) < n // 2, 0.0, 2.0)
    x = motor_noise(n, FS, rng(), profile)
    assert not x[: n // 2].any() and x[n // 2:].std() > 0
    # At a very high speed only the harmonics below 0.45 fs remain: no aliasing to low f.
    fast = MotorNoiseParams(broadband_n_rms=0.0, speed_jitter=0.0, mesh_n=0.0)
    speed = 0.3 * FS / fast.commutation_hz(1.0)        # fundamental at 0.3 fs
    y = motor_noise(n, FS, rng(), speed, fast)
    assert band_rms(y, 20, 0.25 * FS) < 1e-3 * y.std()
    assert np.all(np.isfinite(y))


def test_motor_noise_level_relative_to_contact_transients():
    """The documented levels: at 1 rad/s the motor's peaks equal a slow (about 3 mm/s)
    contact make transient, well above the chain's noise floor, below a 30 mm/s contact."""
    n = FS
    audio = piezo(motor_noise(n, FS, rng(1), 1.0))
    floor = AudioChain().noise_floor_rms()
    assert audio.std() > 3 * floor

    def contact_peak(speed_mm_s: float) -> float:
        f = place(n, np.array([0.1]), np.array([0.004 * speed_mm_s]), half_sine(3e-4, FS), FS)
        return float(np.abs(piezo(f)).max())

    assert contact_peak(1.5) < np.abs(audio).max() < contact_peak(6.0)
    assert np.abs(audio).max() < contact_peak(30.0) / 5
    fast = piezo(motor_noise(n, FS, rng(1), 3.0))
    assert contact_peak(5.0) < np.abs(fast).max() < contact_peak(20.0)


def test_taps_happen_only_at_their_times_and_scatter_in_size():
    n = FS
    times = np.array([0.2, 0.6])
    x = robot_taps(n, FS, rng(), times)
    assert not x[: int(0.2 * FS)].any()
    assert np.abs(x[int(0.2 * FS): int(0.3 * FS)]).max() > 0
    # Rings for tens of milliseconds and has died out before the next tap.
    seg = np.abs(x[int(0.2 * FS): int(0.6 * FS)])
    assert seg[int(0.01 * FS):int(0.02 * FS)].max() > 0.05 * seg.max()
    assert seg[int(0.3 * FS):].max() < 1e-3 * seg.max()
    peaks = [np.abs(robot_taps(n, FS, rng(s), [0.1])).max() for s in range(200)]
    assert np.median(peaks) == pytest.approx(TapParams().median_peak_n, rel=0.15)
    assert np.std(np.log(peaks)) == pytest.approx(TapParams().sigma_log, rel=0.2)
    assert not robot_taps(n, FS, rng(), []).any()
    assert robot_taps(n, FS, rng(), [2.0]).shape == (n,)      # past the end: dropped
    low = robot_taps(n, FS, rng(), [0.1])
    assert band_rms(low, 5000, 20000) < 0.05 * band_rms(low, 50, 2500)


def test_tap_times_are_poisson():
    t = tap_times(1000.0, 0.5, rng())
    assert len(t) == pytest.approx(500, abs=70)
    assert np.all(np.diff(t) >= 0) and t.min() >= 0 and t.max() <= 1000
    assert len(tap_times(10.0, 0.0, rng())) == 0


def test_speech_and_room_noise_levels():
    n = FS
    for level in (60.0, 94.0):
        x = speech(n, FS, rng(), level)
        assert np.sqrt(np.mean(x ** 2)) == pytest.approx(spl_to_pa(level) * 2e-4, rel=1e-6)
    x = speech(n, FS, rng(), 80.0)
    # Speech band: little below 80 Hz or above 5 kHz.
    assert band_rms(x, 100, 4000) > 0.9 * x.std()
    # Syllables: the envelope switches on and off.
    env = np.abs(x).reshape(-1, 441).max(axis=1)
    assert env.min() < 0.1 * env.max()
    r = room_noise(n, FS, rng(), 70.0)
    assert np.sqrt(np.mean(r ** 2)) == pytest.approx(spl_to_pa(70.0) * 2e-4, rel=1e-6)
    assert band_rms(r, 30, 300) > band_rms(r, 3000, 6000)     # pink: more at low f


def test_conversation_is_below_the_preamp_noise_but_a_shout_is_not():
    floor = AudioChain().noise_floor_rms(hum=False)
    talk = piezo(speech(FS, FS, rng(), 65.0))
    shout = piezo(speech(FS, FS, rng(), 100.0))
    assert talk.std() < floor / 2
    assert shout.std() > 10 * floor


def test_mains_hum_has_its_harmonics_and_level():
    x = mains_hum(FS, FS, rng())
    assert x.std() == pytest.approx(hum_rms_v(), rel=0.15)
    assert peak_freq(x) == pytest.approx(50.0, abs=1.0)
    assert band_rms(x, 140, 160) > 0.3 * band_rms(x, 40, 60)          # 3rd harmonic
    assert band_rms(x, 190, 210) < 0.01 * band_rms(x, 40, 60)          # no 4th
    y = mains_hum(FS, FS, rng(), HUM_60)
    assert peak_freq(y) == pytest.approx(60.0, abs=1.0)
    # A harmonic above 0.45 fs is left out rather than aliased.
    z = mains_hum(FS, 1000.0, rng(), HumParams(harmonics=(1, 9), amplitude_uv_rms=(1.0, 100.0)))
    assert z.std() < 2e-6
