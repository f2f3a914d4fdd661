"""Step a scene with its sensors: the loop every scene, test and benchmark shares."""
from __future__ import annotations

from collections.abc import Callable, Sequence

from ._require import mujoco
from .sensor import FingertipSensor

Control = Callable[[float, object], None]
"""Sets ``data.ctrl`` (or mocap poses) for the simulation time given."""


def run(model, data, sensors: Sequence[FingertipSensor], until_s: float,
        control: Control | None = None) -> None:
    """Step until simulation time ``until_s``: control, ``mj_step``, every sensor's step;
    then flush the sensors' pending conversions."""
    mj = mujoco()
    step = mj.mj_step
    while data.time < until_s - 1e-12:
        if control is not None:
            control(data.time, data)
        before = data.time
        step(model, data)
        if data.time <= before:
            raise RuntimeError(f"MuJoCo reset the simulation at t = {before:.4f} s (unstable: "
                               "a smaller timestep or softer gains)")
        for s in sensors:
            s.step()
    for s in sensors:
        s.flush()


def press_and_slide(press_m: float = 0.002, slide_mm_s: float = 20.0, t_press: float = 0.5,
                    t_slide: float = 1.0, axis: int = 0, gap_m: float = 0.01) -> Control:
    """The probe's control: down ``gap_m + press_m`` over ``t_press`` seconds (the servo's
    stiffness turns ``press_m`` past the surface into the normal force), hold, then slide
    along ``axis`` at ``slide_mm_s`` from ``t_slide``."""
    def control(t: float, data) -> None:
        u = 2 * min(t, t_press) / t_press  # first half: the gap; second half: the press
        data.ctrl[2] = -gap_m * min(1.0, u) - press_m * max(0.0, u - 1)
        data.ctrl[axis] = slide_mm_s * 1e-3 * max(0.0, t - t_slide)
    return control
