"""The pinch as a Gymnasium environment: gymnasium's checker, and a scripted policy."""
from __future__ import annotations

import numpy as np
from gymnasium.utils.env_checker import check_env

from fingertip.sim.mujoco.gym_env import PinchEnv


def test_passes_gymnasiums_environment_checker():
    env = PinchEnv(audio=True, max_frames=30)
    check_env(env, skip_render_check=True)
    env.close()


def test_close_then_lift_succeeds_and_the_observation_sees_the_grip():
    env = PinchEnv(audio=True, max_frames=200)
    obs, _ = env.reset(seed=4)
    rest = obs.copy()
    info = {}
    total = 0.0
    for k in range(200):
        action = np.array([1.0, 1.0, 0.0] if k < 25 else [0.0, 0.0, 1.0], np.float32)
        obs, reward, terminated, truncated, info = env.step(action)
        total += reward
        if k == 24:
            squeezed = obs.copy()
        if terminated or truncated:
            break
    assert info["success"] and not info["broken"], info
    assert total > 0.9
    # Counts of the left fingertip moved by far more than their noise when it squeezed.
    assert np.abs(squeezed[:4] - rest[:4]).max() > 0.1
    env.close()
