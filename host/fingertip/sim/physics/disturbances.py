"""What makes a fingertip piezo fire when nothing touches it: the hand's own motors, taps on
the robot, speech and room noise, mains hum.

Every function is pure: (n samples, sample rate, numpy Generator, parameters) -> float64 array
of length n. The mechanical and acoustic sources return an equivalent *dynamic force at the
nail* in newtons, the same quantity the scenes produce, so they go through the same
:class:`~.vibration.AudioChain` (cap modes, piezo, 80 Hz high-pass, preamp, card)::

    chain.finish(chain.filter([Excitation(scene_force + motor_noise(...))], n), 0, rng)

Mains hum is electrical pick-up on the piezo lead: :func:`mains_hum` returns volts at the
preamp *input*, to be added to ``chain.filter(...)`` before ``chain.finish`` (the chain
already adds the parameter file's quiet, steady hum; this is the extra, drifting hum of a
robot whose motor drivers and power supply sit next to the lead).

Levels (why these numbers). The chain maps 1 N of nail force to about 1.0 of sound-card full
scale (0.05 V/N piezo x 20 preamp gain / 1 V full scale; the cap modes add up to +6 dB near
2-9 kHz). Its floor is about -86 dBFS rms (15 nV/rtHz over 22 kHz = 2.2 uV at the input,
i.e. about 45 uN of nail force) plus the parameter file's hum at -60 dBFS. Against that, the
existing scenes give:

- a contact make transient of 4 mN peak per mm/s of approach (:class:`~.scenes.ContactMakeBreak`):
  0.12 N at 30 mm/s, 20 mN at a gentle 5 mm/s;
- sliding textures of 1.6-12 mN rms at 20 mm/s and 1 N (:mod:`.materials`).

Motor noise (:data:`MOTOR`) is set at about 3 mN rms of nail force at a joint speed of
1 rad/s (-46 dBFS rms after the cap modes, 0.019 full-scale peaks in a second), growing in
proportion to speed (0.067 full-scale peaks at 3 rad/s): comparable to a texture, so a moving
hand is clearly audible to the piezo (as every report of "ego-noise" on robot hands says).
Through the chain a make transient peaks at about 0.007 full scale per mm/s of approach, so
the motor's peaks equal the transient of a 3 mm/s approach at 1 rad/s and of a 10 mm/s
approach at 3 rad/s. A fixed vibration threshold that ignores a fast-moving hand would
therefore miss gentle contacts, and one that catches them fires on the motor: that is the
case a force-confirmed (fused) detector has to handle.

Taps on the robot (:data:`TAPS`) reach the fingertip through the arm's structure, low-passed
by the joints and gears and ringing at the arm's modes: median 30 mN peak of nail force,
log-normal scatter of a factor 2 (a knuckle knock on the forearm to the hand bumping a table
elsewhere), i.e. the size of a contact transient but without any force at the gauges.

Airborne sound barely moves a contact piezo under a silicone skin on a rigid cap: the sound
pressure acts on all sides of a body much smaller than the wavelength, so only a small
imbalance is left. :data:`ACOUSTIC` takes 0.2 mN per pascal (a 5 cm^2 cap face with a 40 %
imbalance). Conversational speech at 1 m (60-65 dB SPL, 20-35 mPa) then gives 4-7 uN rms,
below the preamp's own noise; a shout close by (94 dB SPL, 1 Pa) gives 0.2 mN rms (-68 dBFS),
and a loud workshop (85 dB SPL) 70 uN. The model is here so tests can show that speech is not
what makes false contacts (and so a more sensitive mounting can be tried by raising
``n_per_pa``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .vibration import damped_sine, good_fft_size, half_sine, place, smooth_noise

P_REF_PA = 20e-6
"""Reference sound pressure of dB SPL."""


def _check_n_fs(n: int, fs: float) -> None:
    if n < 0:
        raise ValueError(f"n must be >= 0, got {n}")
    if not fs > 0:
        raise ValueError(f"sample rate must be > 0, got {fs}")


def shaped_noise(n: int, fs: float, rng: np.random.Generator, gain_fn) -> np.ndarray:
    """Unit-rms noise of length n whose amplitude spectrum is ``gain_fn(freqs_hz)``."""
    if n == 0:
        return np.zeros(0)
    nfft = good_fft_size(n)
    spec = np.fft.rfft(rng.standard_normal(nfft))
    spec *= gain_fn(np.fft.rfftfreq(nfft, 1 / fs))
    spec[0] = 0
    x = np.fft.irfft(spec, nfft)[:n]
    rms = float(np.sqrt(np.mean(x ** 2))) if n else 0.0
    return x / rms if rms > 0 else x


def band_gain(f: np.ndarray, lo_hz: float, hi_hz: float, order: int = 2) -> np.ndarray:
    """Amplitude of a band-pass (Butterworth-like magnitude, ``order`` each side)."""
    with np.errstate(divide="ignore"):
        hp = 1 / np.sqrt(1 + (lo_hz / np.maximum(f, 1e-9)) ** (2 * order))
    lp = 1 / np.sqrt(1 + (f / hi_hz) ** (2 * order))
    return hp * lp


# --- the hand's own motors ----------------------------------------------------------------

@dataclass(frozen=True)
class MotorNoiseParams:
    """A finger joint driven by a small brushed DC motor through a spur/planetary gearbox.

    The motor turns at ``joint speed * gear_ratio``. Its commutator switches
    ``commutations_per_rev`` times a revolution (a 3-slot brushed motor: 6) and the first
    gear stage meshes ``pinion_teeth`` times a revolution; both give harmonic series whose
    frequencies are proportional to the joint speed. The gearbox adds broadband noise (tooth
    impacts, bearing rumble). All amplitudes are nail-equivalent forces at ``ref_speed_rad_s``
    and scale as (speed / ref) ** ``exponent``.
    """

    gear_ratio: float = 150.0
    commutations_per_rev: int = 6
    pinion_teeth: int = 12
    harmonics: int = 8
    commutation_n: float = 2.5e-3
    """Peak of the commutation fundamental (N); harmonic k has 1 / k of it."""
    mesh_n: float = 2.0e-3
    """Peak of the gear-mesh fundamental (N); harmonic k has 1 / k of it."""
    broadband_n_rms: float = 2.0e-3
    broadband_lo_hz: float = 400.0
    broadband_hi_hz: float = 7000.0
    ref_speed_rad_s: float = 1.0
    exponent: float = 1.0
    speed_jitter: float = 0.02
    """Relative speed ripple (load and PWM), which smears the tones."""
    min_speed_rad_s: float = 0.02
    """Below this the motor is stopped (a held joint is silent)."""

    def __post_init__(self) -> None:
        if self.gear_ratio <= 0 or self.commutations_per_rev < 1 or self.pinion_teeth < 1:
            raise ValueError("gear_ratio, commutations_per_rev and pinion_teeth must be > 0")
        if self.harmonics < 0 or self.ref_speed_rad_s <= 0:
            raise ValueError("harmonics must be >= 0 and ref_speed_rad_s > 0")
        if min(self.commutation_n, self.mesh_n, self.broadband_n_rms) < 0:
            raise ValueError("amplitudes must be >= 0")

    def commutation_hz(self, speed_rad_s: float) -> float:
        """Commutation fundamental at a joint speed (rad/s)."""
        return abs(speed_rad_s) * self.gear_ratio / (2 * math.pi) * self.commutations_per_rev

    def mesh_hz(self, speed_rad_s: float) -> float:
        """Gear-mesh fundamental at a joint speed (rad/s)."""
        return abs(speed_rad_s) * self.gear_ratio / (2 * math.pi) * self.pinion_teeth


MOTOR = MotorNoiseParams()


def motor_noise(n: int, fs: float, rng: np.random.Generator,
                speed_rad_s: float | np.ndarray = 1.0,
                params: MotorNoiseParams = MOTOR) -> np.ndarray:
    """Nail-equivalent force (N) of the hand's own motor, ``n`` samples at ``fs``.

    ``speed_rad_s`` is the joint speed, a number or an array of n samples (a move's speed
    profile); its sign is ignored. The tones follow the speed (their phase is the integral of
    the instantaneous frequency), harmonics at or above 0.45 fs are left out.
    """
    _check_n_fs(n, fs)
    p = params
    speed = np.abs(np.broadcast_to(np.asarray(speed_rad_s, float), (n,))).astype(float)
    if n == 0:
        return np.zeros(0)
    if not np.all(np.isfinite(speed)):
        raise ValueError("speed_rad_s must be finite")
    running = speed >= p.min_speed_rad_s
    if not running.any():
        return np.zeros(n)
    v = speed * (1 + p.speed_jitter * smooth_noise(n, fs, 20.0, rng))
    level = np.where(running, (speed / p.ref_speed_rad_s) ** p.exponent, 0.0)
    rev_hz = v * p.gear_ratio / (2 * math.pi)
    out = np.zeros(n)
    for per_rev, amp in ((p.commutations_per_rev, p.commutation_n),
                         (p.pinion_teeth, p.mesh_n)):
        phase = 2 * math.pi * np.cumsum(rev_hz * per_rev) / fs + rng.uniform(0, 2 * math.pi)
        for k in range(1, p.harmonics + 1):
            fk = k * rev_hz * per_rev
            audible = fk < 0.45 * fs
            if not audible.any():
                break
            out += np.where(audible, amp / k * np.sin(k * phase + rng.uniform(0, 2 * math.pi)),
                            0.0)
    if p.broadband_n_rms > 0:
        out += p.broadband_n_rms * shaped_noise(
            n, fs, rng, lambda f: band_gain(f, p.broadband_lo_hz, p.broadband_hi_hz))
    return out * level


# --- taps on the robot --------------------------------------------------------------------

@dataclass(frozen=True)
class TapParams:
    """A knock on the robot's arm or body, reaching the fingertip through the structure."""

    median_peak_n: float = 0.03
    sigma_log: float = 0.7
    """Log-normal scatter of the peak (0.7: a factor of 2)."""
    pulse_s: float = 5e-4
    """Duration of the knock's force pulse at the arm (a knuckle or a hard edge)."""
    modes: tuple[tuple[float, float, float], ...] = (
        (180.0, 0.05, 1.0), (620.0, 0.04, 0.6), (1500.0, 0.06, 0.3))
    """(frequency Hz, damping ratio, weight) of the arm's ringing after the knock."""
    lowpass_hz: float = 2500.0
    """Joints and gears pass little above a few kilohertz."""

    def __post_init__(self) -> None:
        if self.median_peak_n < 0 or self.sigma_log < 0 or self.pulse_s <= 0:
            raise ValueError("median_peak_n, sigma_log must be >= 0 and pulse_s > 0")


TAPS = TapParams()


def tap_times(duration_s: float, rate_hz: float, rng: np.random.Generator) -> np.ndarray:
    """Poisson arrival times (s, sorted) of ``rate_hz`` events a second over ``duration_s``."""
    if duration_s < 0 or rate_hz < 0:
        raise ValueError("duration_s and rate_hz must be >= 0")
    count = rng.poisson(rate_hz * duration_s)
    return np.sort(rng.uniform(0, duration_s, count))


def robot_taps(n: int, fs: float, rng: np.random.Generator, times_s: np.ndarray,
               params: TapParams = TAPS) -> np.ndarray:
    """Nail-equivalent force (N) of knocks on the robot at ``times_s`` (no force at the
    gauges: only the piezo hears them). Peak amplitudes are drawn from ``params``."""
    _check_n_fs(n, fs)
    p = params
    times = np.asarray(times_s, float)
    if n == 0:
        return np.zeros(0)
    if times.size == 0:
        return np.zeros(n)
    peaks = p.median_peak_n * np.exp(p.sigma_log * rng.standard_normal(times.size))
    length = int(0.08 * fs)
    pulse = half_sine(p.pulse_s, int(fs))
    ring = np.zeros(length)
    if p.modes:
        f0, z, w = (np.array(c, float) for c in zip(*p.modes, strict=True))
        ring = (w[:, None] * damped_sine(f0, z, int(fs), length)).sum(axis=0)
    kern = np.convolve(pulse, ring)[:length] + np.pad(pulse, (0, max(0, length - len(pulse))))
    # Low-pass through the joints, applied to the kernel once (first order, twice).
    spec = np.fft.rfft(kern, 2 * length)
    spec /= (1 + 1j * np.fft.rfftfreq(2 * length, 1 / fs) / p.lowpass_hz) ** 2
    kern = np.fft.irfft(spec, 2 * length)[:length]
    kern /= np.max(np.abs(kern)) or 1.0
    return place(n, times, peaks, kern, int(fs))


# --- speech and room noise ----------------------------------------------------------------

@dataclass(frozen=True)
class AcousticParams:
    """Airborne sound to nail-equivalent force (see the module text for the coupling)."""

    n_per_pa: float = 2e-4
    speech_f0_hz: float = 120.0
    formants_hz: tuple[float, ...] = (500.0, 1500.0, 2500.0)
    syllable_hz: float = 4.0

    def __post_init__(self) -> None:
        if self.n_per_pa < 0 or self.speech_f0_hz <= 0:
            raise ValueError("n_per_pa must be >= 0 and speech_f0_hz > 0")


ACOUSTIC = AcousticParams()


def spl_to_pa(level_db_spl: float) -> float:
    """RMS pressure (Pa) of a sound pressure level (dB re 20 uPa)."""
    return P_REF_PA * 10 ** (level_db_spl / 20)


def speech(n: int, fs: float, rng: np.random.Generator, level_db_spl: float = 65.0,
           params: AcousticParams = ACOUSTIC) -> np.ndarray:
    """Nail-equivalent force (N) of someone speaking nearby at ``level_db_spl`` (rms over the
    talk, pauses included): a jittered glottal pulse train and breath noise through three
    formants, switched on and off at the syllable rate."""
    _check_n_fs(n, fs)
    p = params
    if n == 0:
        return np.zeros(0)
    t = np.arange(n) / fs
    f0 = p.speech_f0_hz * (1 + 0.1 * smooth_noise(n, fs, 3.0, rng))
    phase = np.cumsum(f0) / fs + rng.uniform()
    voiced = (np.diff(np.floor(phase), prepend=np.floor(phase[0])) > 0).astype(float)
    source = voiced + 0.05 * rng.standard_normal(n)
    nfft = good_fft_size(n)
    spec = np.fft.rfft(source, nfft)
    f = np.fft.rfftfreq(nfft, 1 / fs)
    shape = np.zeros_like(f)
    for k, fk in enumerate(p.formants_hz):
        shape += 0.7 ** k / (1 + ((f - fk) / (0.12 * fk)) ** 2)
    spec *= shape * band_gain(f, 80.0, 5000.0)
    x = np.fft.irfft(spec, nfft)[:n]
    env = np.clip(0.5 + 0.8 * np.sin(2 * math.pi * p.syllable_hz * t + rng.uniform(0, 6.3))
                  + 0.3 * smooth_noise(n, fs, 2.0, rng), 0.0, None)
    x *= env
    rms = float(np.sqrt(np.mean(x ** 2)))
    if rms == 0:
        return np.zeros(n)
    return x / rms * spl_to_pa(level_db_spl) * p.n_per_pa


def room_noise(n: int, fs: float, rng: np.random.Generator, level_db_spl: float = 50.0,
               params: AcousticParams = ACOUSTIC) -> np.ndarray:
    """Nail-equivalent force (N) of steady room noise (ventilation, machines): pink noise
    from 30 Hz to 10 kHz at ``level_db_spl`` rms."""
    _check_n_fs(n, fs)
    if n == 0:
        return np.zeros(0)
    x = shaped_noise(n, fs, rng, lambda f: band_gain(f, 30.0, 10000.0, 1)
                     / np.sqrt(np.maximum(f, 1.0)))
    return x * spl_to_pa(level_db_spl) * params.n_per_pa


# --- mains hum ----------------------------------------------------------------------------

@dataclass(frozen=True)
class HumParams:
    """Mains pick-up on the piezo lead (volts rms at the preamp input, per harmonic)."""

    mains_hz: float = 50.0
    harmonics: tuple[int, ...] = (1, 2, 3, 5, 7)
    amplitude_uv_rms: tuple[float, ...] = (100.0, 10.0, 40.0, 15.0, 6.0)
    """Twice the parameter file's steady hum: motor drivers and a switching supply nearby
    (odd harmonics from rectifier and driver currents)."""
    drift: float = 0.1
    """Relative slow amplitude wander (cables and the arm moving in the field)."""
    frequency_error: float = 0.002
    """Grid frequency offset drawn per call, relative (the grid stays within +-0.2 %)."""

    def __post_init__(self) -> None:
        if self.mains_hz <= 0 or len(self.harmonics) != len(self.amplitude_uv_rms):
            raise ValueError("mains_hz must be > 0, one amplitude per harmonic")
        if any(k < 1 for k in self.harmonics) or any(a < 0 for a in self.amplitude_uv_rms):
            raise ValueError("harmonics must be >= 1 and amplitudes >= 0")


HUM_50 = HumParams()
HUM_60 = HumParams(mains_hz=60.0)


def mains_hum(n: int, fs: float, rng: np.random.Generator,
              params: HumParams = HUM_50) -> np.ndarray:
    """Volts at the preamp input of mains hum and its harmonics (random phases, a grid
    frequency a little off nominal, a slow amplitude drift). Harmonics at or above 0.45 fs
    are left out."""
    _check_n_fs(n, fs)
    p = params
    if n == 0:
        return np.zeros(0)
    t = np.arange(n) / fs
    f1 = p.mains_hz * (1 + p.frequency_error * rng.uniform(-1, 1))
    out = np.zeros(n)
    for k, a in zip(p.harmonics, p.amplitude_uv_rms, strict=True):
        if k * f1 >= 0.45 * fs:
            continue
        out += a * 1e-6 * math.sqrt(2) * np.sin(2 * math.pi * k * f1 * t
                                                + rng.uniform(0, 2 * math.pi))
    if p.drift:
        out *= 1 + p.drift * smooth_noise(n, fs, 0.5, rng)
    return out


def hum_rms_v(params: HumParams = HUM_50) -> float:
    """Nominal rms (volts) of :func:`mains_hum` without drift."""
    return math.sqrt(sum((a * 1e-6) ** 2 for a in params.amplitude_uv_rms))
