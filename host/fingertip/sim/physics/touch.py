"""Touches with ground truth, for measuring contact reflexes: a finger moving, touching,
pressing, letting go, while the hand's motors, knocks on the robot, speech and mains hum
reach its piezo (:mod:`.disturbances`).

A :class:`Touch` approaches at ``speed_mm_s`` and touches at ``t_contact_s`` (the truth);
the force then grows as ``stiffness x speed x (t - t_contact)`` until ``force_n``, holds,
and falls at the same rate until the release (the truth of the break). At the make the nail
feels a transient of 4 mN per mm/s of approach (0.3 ms at the nail, 0.4 x and 3 ms on the
skin's side, log-normal scatter 15 %, as :class:`~.scenes.ContactMakeBreak`), at the break
-0.35 x that. While the finger moves, its joint turns at speed / ``LINK_MM`` and the motor
is heard (:func:`~.disturbances.motor_noise`); holding still it is silent.

:func:`render_session` gives the piezo's sound-card samples (through
:class:`~.vibration.AudioChain`) and :func:`force_frames` the force frames at a rate, through
a virtual strain-gauge unit (HX711 counts) and a linear calibration back to newtons, plus the
fingertip's inertial force while the hand accelerates (``CAP_MASS_KG``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .disturbances import (
    HUM_50,
    MOTOR,
    mains_hum,
    motor_noise,
    robot_taps,
    room_noise,
    speech,
    tap_times,
)
from .strain import VirtualStrainSensor
from .vibration import AudioChain, Excitation, half_sine, place, smooth_noise

LINK_MM = 50.0
"""Distance from the finger's joint to the fingertip: joint speed = tip speed / LINK_MM."""
CAP_MASS_KG = 0.004
"""Mass above the gauges (cap, skin, nail, piezo): its inertia reads as force."""
MAKE_N_PER_MM_S = 0.004


@dataclass(frozen=True)
class Touch:
    t_contact_s: float
    speed_mm_s: float
    stiffness_n_per_mm: float
    force_n: float
    hold_s: float = 0.3
    height_mm: float = 2.0
    angle_deg: float = 0.0

    def __post_init__(self) -> None:
        if min(self.speed_mm_s, self.stiffness_n_per_mm, self.force_n) <= 0 or self.hold_s < 0:
            raise ValueError("speed, stiffness and force must be > 0, hold >= 0")

    @property
    def rise_s(self) -> float:
        return self.force_n / (self.stiffness_n_per_mm * self.speed_mm_s)

    @property
    def t_release_s(self) -> float:
        return self.t_contact_s + 2 * self.rise_s + self.hold_s

    @property
    def nail(self) -> bool:
        return self.height_mm < 1.0

    def force(self, t: np.ndarray) -> np.ndarray:
        u = np.asarray(t, float) - self.t_contact_s
        rate = self.stiffness_n_per_mm * self.speed_mm_s
        up = np.clip(u * rate, 0, self.force_n)
        down = np.clip((self.t_release_s - self.t_contact_s - u) * rate, 0, self.force_n)
        return np.minimum(up, down)

    def moving(self, t: np.ndarray, approach_s: float = 0.2, ramp_s: float = 0.03
               ) -> np.ndarray:
        """The fingertip's speed (mm/s): accelerate (``ramp_s``), approach, press, stop;
        unload, withdraw, stop."""
        t = np.asarray(t, float)
        a, b = self.t_contact_s - approach_s, self.t_contact_s + self.rise_s
        c, d = b + self.hold_s, self.t_release_s + approach_s
        up = np.clip(np.minimum(t - a, b - t) / ramp_s + 1, 0, 1) * ((t >= a) & (t < b))
        down = np.clip(np.minimum(t - c, d - t) / ramp_s + 1, 0, 1) * ((t >= c) & (t < d))
        return self.speed_mm_s * np.maximum(np.clip((t - a) / ramp_s, 0, 1) * up,
                                            np.clip((d - t) / ramp_s, 0, 1) * down)


@dataclass
class Session:
    """A stretch of simulated time with its touches and disturbances, and the truth."""

    duration_s: float
    touches: list[Touch]
    seed: int
    fs: int = 44100
    tap_rate_hz: float = 0.0
    speech_db: float | None = None
    room_db: float = 50.0
    free_motion: bool = False
    """The hand also moves between touches (random joint moves up to ``max_speed_rad_s``)."""
    max_speed_rad_s: float = 3.0
    hum: bool = True
    preamp_gain: float | None = None
    tap_s: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def rng(self, stream: int) -> np.random.Generator:
        return np.random.default_rng(np.random.SeedSequence([self.seed, 0x70C4, stream]))

    @property
    def contact_s(self) -> np.ndarray:
        return np.array([t.t_contact_s for t in self.touches])

    @property
    def release_s(self) -> np.ndarray:
        return np.array([t.t_release_s for t in self.touches])

    def true_force(self, t: np.ndarray) -> np.ndarray:
        out = np.zeros(np.shape(t))
        for tc in self.touches:
            out += tc.force(t)
        return out

    def joint_speed(self, t: np.ndarray) -> np.ndarray:
        """rad/s of the finger's joint (the motor noise follows it)."""
        v = np.zeros(np.shape(t))
        for tc in self.touches:
            v = np.maximum(v, tc.moving(t) / LINK_MM)
        if self.free_motion:
            v = np.maximum(v, free_moves(t, self.max_speed_rad_s, self.rng(5)))
        return v

    def motion_starts(self, min_speed_rad_s: float = 0.02) -> np.ndarray:
        """Times (s) at which the joint starts moving (what the hand's controller knows)."""
        t = np.arange(0, self.duration_s, 1e-3)
        moving = self.joint_speed(t) >= min_speed_rad_s
        return t[1:][moving[1:] & ~moving[:-1]] - 1e-3

    def tip_accel(self, t: np.ndarray) -> np.ndarray:
        """m/s^2 of the fingertip (from the joint speed profile)."""
        v = self.joint_speed(t) * LINK_MM * 1e-3
        dt = np.gradient(np.asarray(t, float)) if np.size(t) > 1 else np.ones(1)
        return np.gradient(v) / dt


def free_moves(t: np.ndarray, max_speed: float, rng: np.random.Generator) -> np.ndarray:
    """Joint speed of random point-to-point moves: 0.2-1.5 s at up to ``max_speed``,
    trapezoidal with 60 ms ramps, 0.1-0.8 s pauses (the same rng gives the same moves)."""
    t = np.asarray(t, float)
    out = np.zeros(t.shape)
    if t.size == 0:
        return out
    end = float(t.max())
    s = float(rng.uniform(0, 0.3))
    while s < end:
        dur = float(rng.uniform(0.2, 1.5))
        v = float(rng.uniform(0.1, 1.0)) * max_speed
        ramp = 0.06
        shape = np.clip(np.minimum(t - s, s + dur - t) / ramp, 0, 1)
        out = np.maximum(out, v * shape)
        s += dur + float(rng.uniform(0.1, 0.8))
    return out


def random_touches(n: int, rng: np.random.Generator, *, t0: float = 0.5,
                   speed_range: tuple[float, float] = (5.0, 80.0),
                   force_range: tuple[float, float] = (0.2, 3.0),
                   stiffness_range: tuple[float, float] = (0.25, 3.0),
                   height_range: tuple[float, float] = (0.0, 4.0),
                   gap_range: tuple[float, float] = (0.3, 0.8)) -> list[Touch]:
    """``n`` touches one after another: speeds, forces, stiffnesses log-uniform in their
    ranges, heights uniform, a gap after each release."""
    def logu(lo: float, hi: float) -> float:
        return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))

    out = []
    t = t0
    for _ in range(n):
        tc = Touch(t, logu(*speed_range), logu(*stiffness_range), logu(*force_range),
                   hold_s=float(rng.uniform(0.1, 0.4)),
                   height_mm=float(rng.uniform(*height_range)),
                   angle_deg=float(rng.uniform(-30, 30)))
        out.append(tc)
        t = tc.t_release_s + float(rng.uniform(*gap_range)) + 0.2
    return out


def nail_force(session: Session, n: int) -> np.ndarray:
    """The dynamic nail force (N) of the session's touches and disturbances."""
    fs = session.fs
    rng = session.rng(1)
    f = np.zeros(n)
    for tc in session.touches:
        amp = MAKE_N_PER_MM_S * tc.speed_mm_s * (1.0 if tc.nail else 0.4) \
            * math.exp(0.15 * rng.standard_normal())
        f += place(n, np.array([tc.t_contact_s]), np.array([amp]),
                   half_sine(3e-4 if tc.nail else 3e-3, fs), fs)
        f += place(n, np.array([tc.t_release_s]), np.array([-0.35 * amp]),
                   half_sine(5e-4 if tc.nail else 2e-3, fs), fs)
    t = np.arange(n) / fs
    f += motor_noise(n, fs, session.rng(2), session.joint_speed(t), MOTOR)
    if session.tap_rate_hz > 0:
        session.tap_s = tap_times(session.duration_s, session.tap_rate_hz, session.rng(3))
        f += robot_taps(n, fs, session.rng(4), session.tap_s)
    if session.speech_db is not None:
        # Someone talks for half of the time, in stretches of a few seconds.
        talk = smooth_noise(n, fs, 0.3, session.rng(6)) > 0
        f += speech(n, fs, session.rng(7), session.speech_db) * talk
    f += room_noise(n, fs, session.rng(8), session.room_db)
    return f


def render_session(session: Session) -> np.ndarray:
    """The piezo's float32 sound-card samples over the session."""
    chain = AudioChain(preamp_gain=session.preamp_gain, hum=session.hum)
    n = int(round(session.duration_s * session.fs))
    v = chain.filter([Excitation(nail_force(session, n))], n)
    if session.hum:
        v += mains_hum(n, session.fs, session.rng(9), HUM_50)
    return chain.finish(v, 0, session.rng(10)).samples


def linear_calibration(sensor: VirtualStrainSensor, height_mm: float = 2.0,
                       t0: float = 1000.0) -> np.ndarray:
    """A (5, 2) least-squares map from [counts, 1] to (fx, fy), fitted on the unit's own
    readings of known loads (a 1 N star, 0 and 2 N) at ``height_mm``. Restores the
    sensor's state afterwards is not needed: the loads are far in its future (``t0``)."""
    ang = np.radians(np.arange(0, 360, 30))
    f = np.concatenate([np.zeros((4, 2))] + [m * np.c_[np.cos(ang), np.sin(ang)]
                                             for m in (0.5, 1.0, 2.0)])
    probe = VirtualStrainSensor(sensor.seed, rate_sps=sensor.rate_sps)
    t = t0 + np.arange(len(f)) * 2.0
    c = probe.counts_batch(f, height_mm, t).astype(float)
    a = np.c_[c, np.ones(len(c))]
    return np.linalg.lstsq(a, f, rcond=None)[0]


def force_frames(session: Session, rate_hz: float, unit_seed: int = 100,
                 conversion_s: float = 1 / 80) -> tuple[np.ndarray, np.ndarray]:
    """Force frames (times, magnitude in N) at ``rate_hz``: each frame is the latest 80 SPS
    conversion, the force averaged over its conversion period, read by a virtual unit and
    mapped back to newtons by its linear calibration (tared on the first 0.2 s)."""
    sensor = VirtualStrainSensor(unit_seed, rate_sps=80)
    cal = linear_calibration(sensor)
    t = np.arange(1, int(session.duration_s * rate_hz)) / rate_hz
    sub = 8
    ts = t[:, None] - conversion_s * (np.arange(sub) + 0.5)[None, :] / sub
    mag = session.true_force(ts).mean(axis=1)
    ang = np.zeros(len(t))
    h = np.full(len(t), 2.0)
    for tc in session.touches:
        inside = (t >= tc.t_contact_s) & (t <= tc.t_release_s + conversion_s)
        ang[inside], h[inside] = math.radians(tc.angle_deg), tc.height_mm
    inertial = CAP_MASS_KG * session.tip_accel(ts.ravel()).reshape(ts.shape).mean(axis=1)
    fxy = np.c_[mag * np.cos(ang) + inertial, mag * np.sin(ang)]
    counts = sensor.counts_batch(fxy, h, t).astype(float)
    est = np.c_[counts, np.ones(len(t))] @ cal
    m = np.hypot(est[:, 0], est[:, 1])
    base = t < 0.2
    if base.any():
        tare = est[base].mean(axis=0)
        m = np.hypot(est[:, 0] - tare[0], est[:, 1] - tare[1])
    return t, m


def touch_sessions(total: int, per_session: int, seed: int, **kw) -> list[Session]:
    """``total`` touches in sessions of ``per_session``, seeds ``seed``, ``seed + 1``, ..."""
    out = []
    k = 0
    s = seed
    while k < total:
        m = min(per_session, total - k)
        rng = np.random.default_rng(np.random.SeedSequence([s, 0x7A]))
        touches = random_touches(m, rng, **{a: b for a, b in kw.items()
                                            if a.endswith("_range")})
        dur = touches[-1].t_release_s + 0.6
        out.append(Session(dur, touches, s, **{a: b for a, b in kw.items()
                                               if not a.endswith("_range")}))
        k += m
        s += 1
    return out

