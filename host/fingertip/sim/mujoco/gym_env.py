"""A Gymnasium environment for the pinch: the gripper, the tofu, two fingertips.

One step is one sensor frame (80 SPS). Action (each in [-1, 1]): the left and right fingers'
closing increment (+-0.1 mm per frame) and the arm's vertical increment (+-0.5 mm per frame,
> 0 up). Observation (float32): per fingertip its four tared HX711 counts / 1e5, its closing
travel / 40 mm, and with ``audio`` the log energies of its piezo in four bands (0.1-1, 1-3,
3-8, 8-20 kHz) of the latest audio block; the fingertips' forces are for the policy to learn
from the counts, as on the robot. Reward: the tofu's lift in mm / 20 per step's gain, -1 and
the episode ends when the tofu breaks; the episode is truncated after ``max_frames``.
Success (``info["success"]``): lifted 20 mm, unbroken.
"""
from __future__ import annotations

import numpy as np

from ._require import mujoco
from .experiment import ARM_DOWN_MM
from .gripper import gripper
from .robot import FINGER_ACTUATOR, MujocoArm, MujocoWorld, TARE_CONVERSIONS, open_gap_mm

try:
    import gymnasium as gym
    from gymnasium import spaces
except ImportError as exc:  # the extra is optional
    raise ImportError("Gymnasium is not installed: pip install 'fingertip[mujoco]'") from exc

BANDS_HZ = ((100, 1000), (1000, 3000), (3000, 8000), (8000, 20000))
FINGER_STEP_MM = 0.1
ARM_STEP_MM = 0.5
TOFU_HALF_WIDTH = 0.015
AUDIO_BLOCK = 512
COUNTS_SCALE = 1e5


class PinchEnv(gym.Env):
    """The paper's pinch as an environment (see the module's docstring)."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}

    def __init__(self, *, audio: bool = True, max_frames: int = 400,
                 render_mode: str | None = None, width: int = 320, height: int = 240) -> None:
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', not {render_mode!r}")
        self.audio, self.max_frames, self.render_mode = audio, max_frames, render_mode
        self.size = (width, height)
        # Tared 24-bit counts span +-2^24; log10 band energies from the floor to clipping.
        span = 2 ** 24 / COUNTS_SCALE
        lo = [-span] * 4 + [0.0] + ([-12.0] * len(BANDS_HZ) if audio else [])
        hi = [span] * 4 + [1.0] + ([8.0] * len(BANDS_HZ) if audio else [])
        self.observation_space = spaces.Box(np.array(lo * 2, np.float32),
                                            np.array(hi * 2, np.float32), dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (3,), np.float32)
        self.world: MujocoWorld | None = None
        self._renderer = None

    # --- gymnasium API ---------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        rng = self.np_random
        scene = gripper(("tofu",))
        gap = open_gap_mm(TOFU_HALF_WIDTH)
        start = {f: gap - float(rng.uniform(0.3, 1.3)) for f in FINGER_ACTUATOR}
        seeds = {f: int(rng.integers(0, 2 ** 31 - 1)) for f in FINGER_ACTUATOR}
        options = {"fidelity": "full", "audio_block": AUDIO_BLOCK} if self.audio \
            else {"fidelity": "strain"}
        self.world = MujocoWorld(scene, seeds, start_mm=start, **options)
        MujocoArm(self.world).move_to(0.0, 0.0, ARM_DOWN_MM)
        tare = [self.world.next_readings() for _ in range(TARE_CONVERSIONS)]
        self._tare = {f: np.mean([r[f].counts for r in tare], axis=0) for f in FINGER_ACTUATOR}
        self._bands = {f: np.zeros(len(BANDS_HZ)) for f in FINGER_ACTUATOR}
        self._z0 = self._tofu_z()
        self._lift = 0.0
        self._frames = 0
        return self._observe(self.world.latest), {}

    def step(self, action):
        w = self.world
        if w is None:
            raise RuntimeError("call reset() before step()")
        a = np.clip(np.asarray(action, float), -1.0, 1.0)
        for f, inc in zip(FINGER_ACTUATOR, a[:2], strict=True):
            w.targets_mm[f] = min(max(w.targets_mm[f] + FINGER_STEP_MM * inc, 0.0), 40.0)
        w.arm_target[2] = min(max(w.arm_target[2] + ARM_STEP_MM * 1e-3 * a[2],
                                  ARM_DOWN_MM * 1e-3), 0.0)
        w._apply()
        readings = w.next_readings()
        self._frames += 1
        lift = float(self._tofu_z() - self._z0) * 1e3
        broken = w.breakables.broken["tofu"]
        reward = -1.0 if broken else (lift - self._lift) / 20.0
        self._lift = lift
        success = not broken and lift >= 20.0
        terminated = broken or success
        truncated = self._frames >= self.max_frames and not terminated
        info = {"lift_mm": lift, "broken": broken, "success": success}
        return self._observe(readings), reward, terminated, truncated, info

    def render(self):
        if self.render_mode != "rgb_array" or self.world is None:
            return None
        mj = mujoco()
        if self._renderer is None:
            self._renderer = mj.Renderer(self.world.m, self.size[1], self.size[0])
        self._renderer.update_scene(self.world.d)
        return self._renderer.render()

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    # --- helpers ---------------------------------------------------------------------------

    def _tofu_z(self) -> float:
        m, d = self.world.m, self.world.d
        return min(float(d.xpos[m.body(f"tofu_{h}").id][2]) for h in "ab")

    def _observe(self, readings: dict) -> np.ndarray:
        parts = []
        for f in FINGER_ACTUATOR:
            parts.append((readings[f].counts - self._tare[f]) / COUNTS_SCALE)
            parts.append([self.world.targets_mm[f] / 40.0])
            if self.audio:
                blocks = self.world.sensors[f].audio()
                if blocks:
                    x = blocks[-1].samples.astype(float)
                    spec = np.abs(np.fft.rfft(x)) ** 2
                    freqs = np.fft.rfftfreq(len(x), 1 / blocks[-1].fs)
                    self._bands[f] = np.array([
                        np.log10(spec[(freqs >= lo) & (freqs < hi)].sum() + 1e-12)
                        for lo, hi in BANDS_HZ])
                parts.append(self._bands[f])
        return np.concatenate(parts).astype(np.float32)


def register() -> None:
    """Register ``fingertip/Pinch-v0`` with Gymnasium (``gym.make("fingertip/Pinch-v0")``)."""
    if "fingertip/Pinch-v0" not in gym.registry:
        gym.register("fingertip/Pinch-v0", entry_point=PinchEnv)
