"""Import MuJoCo or say in one line which extra brings it; headless rendering (EGL) where
there is no display, unless the user chose a backend (``MUJOCO_GL``) before."""
from __future__ import annotations

import os
from types import ModuleType

HINT = "MuJoCo is not installed: pip install 'fingertip[mujoco]'"


def mujoco() -> ModuleType:
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        os.environ.setdefault("MUJOCO_GL", "egl")  # read by MuJoCo's first import
    try:
        import mujoco as mj
    except ImportError as exc:  # the extra is optional
        raise ImportError(HINT) from exc
    return mj
