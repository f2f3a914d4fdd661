"""Import MuJoCo or say in one line which extra brings it."""
from __future__ import annotations

from types import ModuleType

HINT = "MuJoCo is not installed: pip install 'fingertip[mujoco]'"


def mujoco() -> ModuleType:
    try:
        import mujoco as mj
    except ImportError as exc:  # the extra is optional
        raise ImportError(HINT) from exc
    return mj
