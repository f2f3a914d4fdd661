"""A simulated four-finger delta hand and arm in a 1D-per-finger kinematic world.

Each finger closes along its own axis towards an object; its contact force is Hooke's law
on the penetration into the object's surface (``stiffness_n_per_mm``), and an object whose
contact force exceeds ``crush_n`` breaks. The force on each fingertip goes through that
finger's :class:`~fingertip.sim.physics.VirtualStrainSensor` (its own seeded unit, with
noise, hysteresis and creep) and comes out as HX711 counts in a :class:`Frame`, exactly as a
real fingertip would stream them; each unit has a force model fitted on its own simulated
calibration sweep (cached on disk, about 0.7 s per unit the first time).

Time is simulated: one :meth:`SimHand.read` advances the world by one sensor period. The
arm logs its height at every step (:meth:`SimArm.z_history`), and each fingertip's contact
microphone is rendered only for the scenes a world starts (:mod:`.audio_bus`):
:mod:`.cups` and :mod:`.boxes` build the cup stack and the two boxes on this world.
"""
from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...device import Frame
from ..physics import AudioChain, VirtualStrainSensor, calibration_sweep
from ...tasks.interfaces import AudioBlock, FrameSet, RobotArm, RobotHand
from .audio_bus import AudioBus
from .cache import cached

RATE_SPS = 80
FINGERS = ("f0", "f1", "f2", "f3")
_TARE_SAMPLES = 16


@dataclass(frozen=True)
class ObjectSpec:
    name: str
    stiffness_n_per_mm: float
    crush_n: float
    mass_kg: float
    friction: float = 0.5


TOFU = ObjectSpec("tofu", stiffness_n_per_mm=0.25, crush_n=1.5, mass_kg=0.012)
CHIP = ObjectSpec("chip", stiffness_n_per_mm=3.0, crush_n=0.4, mass_kg=0.002)


def tare_counts(sensor: VirtualStrainSensor, t0: float = 0.0) -> np.ndarray:
    t = t0 + np.arange(1, _TARE_SAMPLES + 1) / sensor.rate_sps
    return sensor.counts_batch(np.zeros((_TARE_SAMPLES, 2)), 0.0, t).mean(axis=0)


def unit_force_model(unit_seed: int):
    """The force model of virtual unit ``unit_seed``, fitted once on its calibration sweep."""
    from ... import __version__, models
    from ...models.force.calibrate import fit_calibration, from_arrays
    from ...models.nets.fit_cache import fit_key
    from ...models.force.runtime import ForceModel
    from .. import physics

    fit = {"unit_seed": unit_seed, "rate_sps": RATE_SPS, "tare_samples": _TARE_SAMPLES,
           "models": "mlp16x16", "epochs": 300, "t0_us": 1_000_000}
    # Keyed by the fit's parameters and by the code that simulates and fits the unit, so a
    # model fitted by older code is never reused (it was, with the unit's seed alone).
    key = fit_key(fit, [Path(__file__), Path(physics.__file__).parent,
                        Path(models.__file__).parent], __version__)

    def build(folder: Path) -> None:
        sensor = VirtualStrainSensor(unit_seed, rate_sps=RATE_SPS)
        tare = tare_counts(sensor)
        sw = calibration_sweep(sensor, seed=unit_seed, t0_us=fit["t0_us"])
        data = from_arrays(sw.counts - tare, sw.fx, sw.fy, angle_deg=sw.angle_deg,
                           height_mm=sw.height_mm, trial=sw.trial)
        fit_calibration(data, folder, models=fit["models"], epochs=fit["epochs"], plot=False)

    return ForceModel(cached(f"unit{unit_seed}-{key}", "force.onnx", build))


@dataclass
class Fault:
    """A sensor fault injected from ``at_s`` (sim time) on: ``"nan"`` counts, ``"timeout"``
    bits, or ``"silent"`` (no frames at all)."""

    kind: str
    at_s: float
    finger: str = "f0"


@dataclass
class SimObject:
    spec: ObjectSpec
    gaps_mm: dict[str, float]
    """Each finger's closing travel at which it touches the surface."""
    broken: bool = False
    lifted_mm: float = 0.0
    peak_force_n: float = 0.0


@dataclass
class SimWorld:
    """The world: an object between the fingers, the arm height, the simulated clock."""

    obj: SimObject
    rng: np.random.Generator
    t_s: float = 1.0
    arm_z_mm: float = 0.0
    slide: tuple[float, float] | None = None      # (target z, speed)
    shake: tuple[float, float, float, float] | None = None  # (start, amplitude, Hz, duration)
    arm_x_mm: float = 0.0
    arm_xy_mm: tuple[float, float] = (0.0, 0.0)
    """Where the arm was sent (:meth:`SimArm.move_to`); ``arm_x_mm`` is the shake's offset."""
    positions: dict[str, float] = field(default_factory=lambda: dict.fromkeys(FINGERS, 0.0))
    max_travel_mm: float = 30.0
    angles_deg: dict[str, float] = field(default_factory=dict)
    heights_mm: dict[str, float] = field(default_factory=dict)
    fault: Fault | None = None
    audio_seed: int = 0
    chain_options: dict = field(default_factory=dict)
    """Keyword arguments of the fingertips' :class:`AudioChain` (gain, mains frequency)."""
    finger_z_mm: dict[str, float] = field(default_factory=lambda: dict.fromkeys(FINGERS, 0.0))
    """Each fingertip's vertical offset (:meth:`SimHand.step_z`)."""
    z_log: list[tuple[float, float]] = field(default_factory=list)
    _bus: AudioBus | None = None

    @property
    def audio(self) -> AudioBus:
        if self._bus is None:
            rng = np.random.default_rng(np.random.SeedSequence([self.audio_seed, 0xA0D10]))
            self._bus = AudioBus(AudioChain(**self.chain_options), rng)
        return self._bus

    def log_z(self) -> None:
        if self.z_log and self.z_log[-1][0] >= self.t_s:
            self.z_log[-1] = (self.t_s, self.arm_z_mm)
        else:
            self.z_log.append((self.t_s, self.arm_z_mm))

    # Motions start here, so that a world with objects can react to them (hooks).
    def start_slide(self, dz_mm: float, speed_mm_s: float) -> None:
        self.slide = (self.arm_z_mm + dz_mm, speed_mm_s)
        self.log_z()

    def start_shake(self, amplitude_mm: float, frequency_hz: float, duration_s: float) -> None:
        self.shake = (self.t_s, amplitude_mm, frequency_hz, duration_s)

    def stop_motion(self) -> None:
        self.slide = None
        self.shake = None
        self.arm_x_mm = 0.0

    def step_fingers_z(self, increments_mm: Mapping[str, float]) -> None:
        for f, d in increments_mm.items():
            self.finger_z_mm[f] = min(max(self.finger_z_mm[f] + float(d), -5.0), 5.0)

    def contact_forces(self) -> dict[str, float]:
        s = self.obj.spec
        f = {k: max(0.0, p - self.obj.gaps_mm[k]) * s.stiffness_n_per_mm
             for k, p in self.positions.items()}
        if self.obj.broken:                       # crushed: it gives way under the fingers
            f = {k: 0.2 * v for k, v in f.items()}
        return f

    def holds(self) -> bool:
        """Whether the fingers carry the object: friction x total grip >= its weight."""
        grip = self.obj.spec.friction * sum(self.contact_forces().values())
        return grip >= self.obj.spec.mass_kg * 9.81 and not self.obj.broken

    def advance(self, dt: float) -> None:
        self.t_s += dt
        forces = self.contact_forces()
        peak = max(forces.values())
        self.obj.peak_force_n = max(self.obj.peak_force_n, peak)
        if not self.obj.broken and peak > self.obj.spec.crush_n:
            self.obj.broken = True
        if self.shake is not None:
            # Horizontal shake about the start position: x = A sin(2 pi f t) for the duration.
            t0, amp, hz, dur = self.shake
            u = self.t_s - t0
            if u >= dur:
                self.arm_x_mm = 0.0
                self.shake = None
            else:
                self.arm_x_mm = amp * math.sin(2 * math.pi * hz * u)
        if self.slide is not None:
            target, speed = self.slide
            dz = math.copysign(min(abs(target - self.arm_z_mm), speed * dt),
                               target - self.arm_z_mm)
            self.arm_z_mm += dz
            if self.holds():
                self.obj.lifted_mm = max(0.0, self.obj.lifted_mm + dz)
            else:
                self.obj.lifted_mm = 0.0          # slipped out and fell back
            if abs(target - self.arm_z_mm) < 1e-9:
                self.slide = None
        self.log_z()


class SimHand(RobotHand):
    """A four-finger delta hand in a :class:`SimWorld`, one virtual fingertip per finger."""

    def __init__(self, world: SimWorld, unit_seeds: Mapping[str, int]) -> None:
        self.world = world
        self._sensors = {f: VirtualStrainSensor(unit_seeds[f], rate_sps=RATE_SPS)
                         for f in FINGERS}
        self._models = {f: unit_force_model(unit_seeds[f]) for f in FINGERS}
        self._tares = {f: tare_counts(s, world.t_s - 1.0) for f, s in self._sensors.items()}
        self._seq = 0

    @property
    def fingers(self) -> list[str]:
        return list(FINGERS)

    def step(self, increments_mm: Mapping[str, float]) -> None:
        w = self.world
        for f, d in increments_mm.items():
            w.positions[f] = min(max(w.positions[f] + float(d), 0.0), w.max_travel_mm)

    def positions(self) -> dict[str, float]:
        return dict(self.world.positions)

    def force_model(self, finger: str):
        return self._models[finger]

    def read_audio(self, finger: str) -> AudioBlock:
        if finger not in FINGERS:
            raise ValueError(f"no finger {finger!r}; fingers: {FINGERS}")
        return self.world.audio.read(finger, self.world.t_s)

    def step_z(self, increments_mm: Mapping[str, float]) -> None:
        self.world.step_fingers_z(increments_mm)

    def read(self, timeout: float = 0.5) -> FrameSet | None:
        self.world.advance(1.0 / RATE_SPS)
        return self.frame_set()

    def frame_set(self) -> FrameSet | None:
        """Every fingertip's frame at the world's present time (None: a silent fault)."""
        w = self.world
        fault = w.fault if w.fault is not None and w.t_s >= w.fault.at_s else None
        if fault is not None and fault.kind == "silent":
            return None
        forces = w.contact_forces()
        self._seq += 1
        out = {}
        for f in FINGERS:
            a = math.radians(w.angles_deg.get(f, 0.0))
            fxy = np.array([[forces[f] * math.cos(a), forces[f] * math.sin(a)]])
            c = self._sensors[f].counts_batch(fxy, w.heights_mm.get(f, 2.0), np.array([w.t_s]))
            counts: tuple = tuple(int(v) for v in np.rint(c[0] - self._tares[f]))
            tmask = 0
            if fault is not None and fault.finger == f:
                if fault.kind == "nan":
                    counts = (math.nan,) * len(counts)
                elif fault.kind == "timeout":
                    tmask = 0b0001
            out[f] = Frame(seq=self._seq, device_time_us=int(w.t_s * 1e6), host_time=w.t_s,
                           arrival_time=time.monotonic(), counts=counts, timeout_mask=tmask)
        return out


class SimArm(RobotArm):
    """The arm of a :class:`SimWorld`: only the vertical axis matters in this world."""

    def __init__(self, world: SimWorld) -> None:
        self.world = world

    def move_to(self, x_mm: float, y_mm: float, z_mm: float) -> None:
        self.world.arm_xy_mm = (x_mm, y_mm)
        self.world.arm_z_mm = z_mm
        self.world.log_z()

    def position(self) -> tuple[float, float, float]:
        x, y = self.world.arm_xy_mm
        return (x + self.world.arm_x_mm, y, self.world.arm_z_mm)

    def slide_z(self, dz_mm: float, speed_mm_s: float) -> None:
        if speed_mm_s <= 0:
            raise ValueError("speed must be > 0")
        self.world.start_slide(dz_mm, speed_mm_s)

    def shake(self, amplitude_mm: float, frequency_hz: float, duration_s: float) -> None:
        """A kinematic x(t) = A sin(2 pi f t); a world holding a box makes its contents
        sound (:mod:`.boxes`)."""
        if amplitude_mm <= 0 or frequency_hz <= 0 or duration_s <= 0:
            raise ValueError("amplitude, frequency and duration must be > 0")
        self.world.start_shake(amplitude_mm, frequency_hz, duration_s)

    def moving(self) -> bool:
        return self.world.slide is not None or self.world.shake is not None

    def stop(self) -> None:
        self.world.stop_motion()

    def z_history(self, since: float) -> tuple[np.ndarray, np.ndarray]:
        log = self.world.z_log
        i = next((k for k, (t, _) in enumerate(log) if t >= since), len(log))
        # One entry before ``since`` too, so that any time from ``since`` on is bracketed.
        a = np.array(log[max(0, i - 1):], dtype=float).reshape(-1, 2)
        return a[:, 0].copy(), a[:, 1].copy()


def make_world(spec: ObjectSpec, seed: int, *, hand_seed: int = 100,
               fault: Fault | None = None, hand_factory=SimHand
               ) -> tuple[SimWorld, SimHand, SimArm]:
    """One trial: the object placed off-centre by a seeded amount (each finger touches it
    after 0.3-1.3 mm of travel), seeded contact angles and heights on the fingertips. The
    four fingertips are virtual units ``hand_seed`` .. ``hand_seed + 3``; ``hand_factory``
    (world, unit seeds) builds the hand (a :class:`SimHand` or a subclass)."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, 8]))
    gaps = {f: float(rng.uniform(0.3, 1.3)) for f in FINGERS}
    world = SimWorld(SimObject(spec, gaps), rng,
                     angles_deg={f: float(rng.uniform(-20, 20)) for f in FINGERS},
                     heights_mm={f: float(rng.uniform(1.0, 4.0)) for f in FINGERS},
                     fault=fault)
    hand = hand_factory(world, {f: hand_seed + i for i, f in enumerate(FINGERS)})
    return world, hand, SimArm(world)
