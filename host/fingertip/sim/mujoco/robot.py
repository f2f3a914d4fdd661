"""``RobotHand`` and ``RobotArm`` on the MuJoCo gripper, so the recipes of ``tasks/`` run
unchanged on real rigid-body dynamics.

Time is simulated: :meth:`MujocoHand.read` steps the physics until every fingertip has made
its next HX711 conversion (80 SPS) and returns one :class:`Frame` per finger, its counts tared
as the device tares them (the mean of the first conversions, fingers open). Each fingertip is
a virtual unit with its own seed and the force model fitted on that unit's calibration sweep
(the same cached fit as the virtual world's hand). The arm's motions (``slide_z``, ``shake``)
are targets of its position servos that move while the recipe reads frames.
"""
from __future__ import annotations

import math
import time
from collections.abc import Mapping

import numpy as np

from ._require import mujoco
from .gripper import FINGER_OPEN_Y
from .project import AudioBlock, Frame, FrameSet, RobotArm, RobotHand, unit_force_model
from .scenes import Scene
from .sensor import FingertipSensor

TARE_CONVERSIONS = 16
HAND_UNIT = 100
"""The left fingertip's virtual unit; the right one is the next (the virtual world's hand
starts at the same seed)."""
TRAVEL_MM = 40.0
FINGER_ACTUATOR = {"left": 3, "right": 4}
ARM_ACTUATORS = (0, 1, 2)


class MujocoWorld:
    """A hand scene with its sensors, the motion targets and the step loop.

    The scene says which actuators move what (``scene.info``): ``fingers`` (finger -> its
    closing actuator; default the gripper's), ``finger_z`` (finger -> its vertical actuator,
    for :meth:`MujocoZHand.step_z`), ``updates`` (callables run on the data after every
    step: objects that break, fits that let go) and ``breakables`` (the gripper's).
    ``fidelity`` is one level for every fingertip or one per finger (a scene's other
    fingertips need no audio).
    """

    def __init__(self, scene: Scene, unit_seeds: Mapping[str, int], *,
                 fidelity: str | Mapping[str, str] = "strain",
                 start_mm: Mapping[str, float] | None = None, **sensor_options) -> None:
        self.scene = scene
        self.m, self.d = scene.model, scene.data
        self.fingers: dict[str, int] = dict(scene.info.get("fingers", FINGER_ACTUATOR))
        self.finger_z: dict[str, int] = dict(scene.info.get("finger_z", {}))
        self.travel_mm = float(scene.info.get("travel_mm", TRAVEL_MM))
        self.breakables = scene.info.get("breakables")
        self.updates = list(scene.info.get("updates", ()))
        if self.breakables is not None:
            self.updates.insert(0, self.breakables.update)
        level = {f: fidelity if isinstance(fidelity, str) else fidelity[f]
                 for f in self.fingers}
        sensor_options.setdefault("materials", scene.materials)
        self.sensors = {f: FingertipSensor(self.m, self.d, scene.tips[f], fidelity=level[f],
                                           seed=unit_seeds[f], batch=1, **sensor_options)
                        for f in self.fingers}
        # Where each finger's travel counts from (the hand placed close to the object).
        self.start_mm = dict(start_mm or dict.fromkeys(self.fingers, 0.0))
        self.targets_mm = dict.fromkeys(self.fingers, 0.0)
        self.speeds_mm_s = dict.fromkeys(self.fingers, 0.0)
        self.z_mm = dict.fromkeys(self.finger_z, 0.0)
        self.arm_target = np.zeros(3)
        self._arm_z = int(self.m.jnt_qposadr[self.m.actuator_trnid[ARM_ACTUATORS[2], 0]])
        self.slide: tuple[float, float] | None = None
        self.shake: tuple[float, float, float, float, float] | None = None
        self.x_return: tuple[float, float] | None = None
        self.z_log: list[tuple[float, float]] = []
        """(time, the arm's measured height in mm): what a robot's joint encoders log."""
        self.latest: dict[str, object] = {}
        self._apply()

    def _apply(self) -> None:
        for f, a in self.fingers.items():
            self.d.ctrl[a] = (self.start_mm[f] + self.targets_mm[f]) * 1e-3
        for f, a in self.finger_z.items():
            self.d.ctrl[a] = self.z_mm[f] * 1e-3
        self.d.ctrl[list(ARM_ACTUATORS)] = self.arm_target

    def _motion(self, dt: float) -> None:
        for f, v in self.speeds_mm_s.items():
            if v:
                self.targets_mm[f] = min(max(self.targets_mm[f] + v * dt, 0.0), self.travel_mm)
        if self.slide is not None:
            target, speed = self.slide
            z = self.arm_target[2]
            step = math.copysign(min(abs(target - z), speed * 1e-3 * dt), target - z)
            self.arm_target[2] = z + step
            if abs(target - self.arm_target[2]) < 1e-12:
                self.slide = None
        if self.shake is not None:
            t0, x0, amp, hz, dur = self.shake
            u = self.d.time - t0
            if u >= dur:
                # The paper's 5.6 s end near a peak: the arm comes back to the centre at the
                # shake's own peak speed (a 50 mm jump of the servo's target would fling it).
                self.shake = None
                self.x_return = (x0, amp * 2 * math.pi * hz)
            else:
                self.arm_target[0] = x0 + amp * 1e-3 * math.sin(2 * math.pi * hz * u)
        if self.x_return is not None:
            x0, speed = self.x_return
            x = self.arm_target[0]
            self.arm_target[0] = x + math.copysign(min(abs(x0 - x), speed * 1e-3 * dt), x0 - x)
            if abs(x0 - self.arm_target[0]) < 1e-12:
                self.x_return = None
        self._apply()

    def step(self) -> None:
        """One physics step with every sensor and the scene's updates."""
        self._motion(self.m.opt.timestep)
        mujoco().mj_step(self.m, self.d)
        for s in self.sensors.values():
            s.step()
        for update in self.updates:
            update(self.d)
        self.z_log.append((self.d.time, float(self.d.qpos[self._arm_z] * 1e3)))

    def next_readings(self) -> dict:
        """Step until every fingertip has a new conversion; the latest of each."""
        got: dict = {}
        while len(got) < len(self.sensors):
            self.step()
            for f, s in self.sensors.items():
                rs = s.readings()
                if rs:
                    got[f] = rs[-1]
        self.latest = got
        return got


class MujocoHand(RobotHand):
    """The scene's fingers (the gripper's ``left``, ``right``), one virtual fingertip each."""

    def __init__(self, world: MujocoWorld, unit_seeds: Mapping[str, int]) -> None:
        self.world = world
        self._models = {f: unit_force_model(unit_seeds[f]) for f in world.fingers}
        tares = [world.next_readings() for _ in range(TARE_CONVERSIONS)]
        self._tares = {f: np.mean([r[f].counts for r in tares], axis=0)
                       for f in world.fingers}
        self._seq = 0
        self._audio_t = dict.fromkeys(world.fingers, world.d.time)

    @property
    def fingers(self) -> list[str]:
        return list(self.world.fingers)

    def step(self, increments_mm: Mapping[str, float]) -> None:
        w = self.world
        for f, inc in increments_mm.items():
            w.targets_mm[f] = min(max(w.targets_mm[f] + float(inc), 0.0), w.travel_mm)
        w._apply()

    def move(self, speeds_mm_s: Mapping[str, float]) -> None:
        for f, v in speeds_mm_s.items():
            self.world.speeds_mm_s[f] = float(v)

    def positions(self) -> dict[str, float]:
        return dict(self.world.targets_mm)

    def force_model(self, finger: str):
        return self._models[finger]

    def read(self, timeout: float = 0.5) -> FrameSet | None:
        rs = self.world.next_readings()
        self._seq += 1
        now = time.monotonic()
        return {f: Frame(seq=self._seq, device_time_us=int(round(r.t * 1e6)), host_time=r.t,
                         arrival_time=now,
                         counts=tuple(int(v) for v in np.rint(r.counts - self._tares[f])))
                for f, r in rs.items()}

    def read_audio(self, finger: str) -> AudioBlock:
        s = self.world.sensors[finger]
        blocks = s.audio()
        if not blocks:
            return AudioBlock(np.zeros(0, np.float32), 44100.0, self._audio_t[finger])
        samples = np.concatenate([b.samples for b in blocks])
        out = AudioBlock(samples, float(blocks[0].fs), blocks[0].t0)
        self._audio_t[finger] = out.t_end
        return out


class MujocoZHand(MujocoHand):
    """A hand whose fingers also move vertically (``scene.info["finger_z"]``), as the cup
    recipe's separation strokes need."""

    Z_LIMIT_MM = 5.0

    def step_z(self, increments_mm: Mapping[str, float]) -> None:
        w = self.world
        for f, inc in increments_mm.items():
            if f not in w.finger_z:
                raise ValueError(f"finger {f!r} has no vertical joint; fingers: "
                                 f"{', '.join(w.finger_z)}")
            w.z_mm[f] = min(max(w.z_mm[f] + float(inc), -self.Z_LIMIT_MM), self.Z_LIMIT_MM)
        w._apply()


def make_hand(world: MujocoWorld, unit_seeds: Mapping[str, int]) -> MujocoHand:
    """The hand class the scene supports: with vertical finger motion when it has it."""
    return (MujocoZHand if world.finger_z else MujocoHand)(world, unit_seeds)


class MujocoArm(RobotArm):
    """The gantry arm: targets of its servos in mm from its home position."""

    SETTLE_MM = 0.2
    SETTLE_TIMEOUT_S = 5.0

    STALL_MM = 3.0
    STALL_S = 0.2

    def __init__(self, world: MujocoWorld, travel_z_mm: float | None = None,
                 speed_mm_s: float | None = None, straight_mm: float = 1.0) -> None:
        """``travel_z_mm``: a move with a horizontal part longer than ``straight_mm`` goes up
        to this height first, across, then down (as a robot's planner avoids what stands
        between two places; a shorter one, stepping aside at the same place, goes straight);
        None: one straight move. ``speed_mm_s``: moves go along a straight line at this
        speed and end where the arm stops within ``STALL_MM`` of the goal (pressing what it
        holds on the table, as a robot's compliant servo does); None: the servos' targets
        jump to the goal and the move ends within ``SETTLE_MM`` of it."""
        self.world = world
        self.travel_z_mm = travel_z_mm
        self.speed_mm_s = speed_mm_s
        self.straight_mm = straight_mm
        self._qadr = [int(world.m.jnt_qposadr[world.m.actuator_trnid[a, 0]])
                      for a in ARM_ACTUATORS]

    def move_to(self, x_mm: float, y_mm: float, z_mm: float) -> None:
        here = self.world.arm_target * 1e3
        across = math.hypot(x_mm - here[0], y_mm - here[1])
        if self.travel_z_mm is not None and across > self.straight_mm:
            top = max(self.travel_z_mm, z_mm)
            self._move(here[0], here[1], top)
            self._move(x_mm, y_mm, top)
        self._move(x_mm, y_mm, z_mm)

    def _move(self, x_mm: float, y_mm: float, z_mm: float) -> None:
        w = self.world
        goal = np.array([x_mm, y_mm, z_mm]) * 1e-3
        w.slide = w.shake = w.x_return = None
        if self.speed_mm_s is not None:
            dt = w.m.opt.timestep
            while (gap := float(np.linalg.norm(goal - w.arm_target))) > 1e-9:
                w.arm_target += (goal - w.arm_target) * min(1.0, self.speed_mm_s * 1e-3 * dt / gap)
                w.step()
        w.arm_target[:] = goal
        w._apply()
        t_end = w.d.time + self.SETTLE_TIMEOUT_S
        still, last = 0.0, self._actual()
        while (err := np.abs(self._actual() - w.arm_target).max() * 1e3) > self.SETTLE_MM:
            if self.speed_mm_s is not None and err < self.STALL_MM:
                now = self._actual()
                moved = np.abs(now - last).max() * 1e3
                last = now
                still = still + w.m.opt.timestep if moved < 1e-3 else 0.0
                if still >= self.STALL_S:
                    return
            if w.d.time > t_end:
                raise RuntimeError(f"the arm did not reach {x_mm, y_mm, z_mm} mm")
            w.step()

    def _actual(self) -> np.ndarray:
        return np.array([self.world.d.qpos[a] for a in self._qadr])

    def position(self) -> tuple[float, float, float]:
        x, y, z = self._actual() * 1e3
        return (float(x), float(y), float(z))

    def slide_z(self, dz_mm: float, speed_mm_s: float) -> None:
        if speed_mm_s <= 0:
            raise ValueError("speed must be > 0")
        w = self.world
        w.slide = (w.arm_target[2] + dz_mm * 1e-3, speed_mm_s)

    def shake(self, amplitude_mm: float, frequency_hz: float, duration_s: float) -> None:
        if amplitude_mm <= 0 or frequency_hz <= 0 or duration_s <= 0:
            raise ValueError("amplitude, frequency and duration must be > 0")
        w = self.world
        w.shake = (w.d.time, float(w.arm_target[0]), amplitude_mm, frequency_hz, duration_s)

    def moving(self) -> bool:
        w = self.world
        return w.slide is not None or w.shake is not None or w.x_return is not None

    def stop(self) -> None:
        """Hold where the arm is now."""
        w = self.world
        w.slide = w.shake = w.x_return = None
        w.arm_target[:] = self._actual()
        w._apply()

    def z_history(self, since: float) -> tuple[np.ndarray, np.ndarray]:
        log = [e for e in self.world.z_log if e[0] >= since]
        a = np.array(log, float).reshape(-1, 2)
        return a[:, 0].copy(), a[:, 1].copy()


def open_gap_mm(object_half_width_m: float) -> float:
    """Closing travel from open to touching an object of this half width, centred (mm)."""
    from .attach import geometry

    return (FINGER_OPEN_Y - geometry().half_width - object_half_width_m) * 1e3
