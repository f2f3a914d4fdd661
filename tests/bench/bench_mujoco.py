"""The fingertip as a MuJoCo sensor: what each fidelity costs, and how fast a gripper runs.

- ``mujoco_sensor_us_per_step_<fidelity>``: CPU microseconds one fingertip's sensor adds to
  each physics step (2 ms), measured on the probe pressing and sliding over coarse fabric
  (contacts every step after the touch): the same scene stepped with and without the sensor,
  side by side in one run (median of repeats, interleaved), the difference per step.
- ``mujoco_step_us_probe``: the physics step itself in that scene (MuJoCo, no sensor).
- ``mujoco_realtime_factor_full``: simulated seconds per wall second of the gripper scene
  (arm, two fingers, two fingertips at ``full``: counts and audio, the tofu pinched, lifted),
  everything included (control, steps, sensors, breaking); the CPU time of this process
  (one core), so that other load on a shared machine does not count.

- ``mujoco_pinch_success`` (of 50: the paper's 25 tofu + 25 chip) on the MuJoCo gripper with
  the recipe of ``tasks/pinch.py`` unchanged, beside ``mujoco_pinch_world_success``, the same
  recipe, thresholds and seeds in today's virtual world (``sim/experiment.py``), in this run.

Single thread, pinned to one core where possible.
"""
from __future__ import annotations

import os
import statistics
import time

from fingertip.sim import experiment as world_experiment
from fingertip.sim.mujoco import FIDELITIES, FingertipSensor
from fingertip.sim.mujoco import experiment as mujoco_experiment
from fingertip.sim.mujoco.drive import press_and_slide
from fingertip.sim.mujoco.drive import run as step_scene
from fingertip.sim.mujoco.gripper import gripper
from fingertip.sim.mujoco.scenes import probe

SECONDS = 3.0
REPEATS = 5


def _probe_run(fidelity: str | None) -> tuple[float, int]:
    """CPU seconds and steps of the probe scene with one sensor (None: none)."""
    sc = probe(("coarse_fabric",))
    sensors = [] if fidelity is None else [FingertipSensor(
        sc.model, sc.data, sc.tips["tip"], fidelity=fidelity, materials=sc.materials)]
    control = press_and_slide(slide_mm_s=20.0, t_press=0.3, t_slide=0.4)
    c0 = time.process_time()
    step_scene(sc.model, sc.data, sensors, SECONDS, control)
    return time.process_time() - c0, round(SECONDS / sc.model.opt.timestep)


def sensor_costs(repeats: int = REPEATS) -> dict[str, float]:
    """Microseconds per step each fidelity adds, measured interleaved with the bare scene."""
    levels: list[str | None] = [None, *FIDELITIES]
    times: dict[str | None, list[float]] = {k: [] for k in levels}
    steps = 0
    _probe_run("full")  # warm up (imports, FFT plans, the texture profile)
    for _ in range(repeats):
        for level in levels:
            cpu, steps = _probe_run(level)
            times[level].append(cpu)
    bare = statistics.median(times[None])
    out = {"mujoco_step_us_probe": round(bare / steps * 1e6, 1)}
    for level in FIDELITIES:
        out[f"mujoco_sensor_us_per_step_{level}"] = round(
            (statistics.median(times[level]) - bare) / steps * 1e6, 1)
    return out


def gripper_realtime_factor(seconds: float = SECONDS) -> float:
    """Simulated seconds per CPU second: the gripper pinching and lifting the tofu."""
    sc = gripper(("tofu",))
    m, d = sc.model, sc.data
    brk = sc.info["breakables"]
    sensors = [FingertipSensor(m, d, tip, fidelity="full", seed=i)
               for i, tip in enumerate(sc.tips.values())]
    down = -0.1 + 0.004  # the fingertips' lower 5 mm beside the tofu's top
    c0 = time.process_time()

    def control(t: float, data) -> None:
        data.ctrl[2] = down * min(1.0, t / 0.5) + 0.05 * min(1.0, max(0.0, t - 2.0) / 0.5)
        data.ctrl[3] = data.ctrl[4] = 0.0235 * min(1.0, max(0.0, t - 0.6) / 1.0)
        brk.update(data)

    step_scene(m, d, sensors, seconds, control)
    return seconds / (time.process_time() - c0)


def pinch_figures(trials: int = 25) -> dict[str, float]:
    """The paper's pinch in both worlds, the same thresholds (the virtual world's
    demonstration) and seeds."""
    out: dict[str, float] = {}
    total = {"mujoco": 0, "world": 0}
    for name in ("tofu", "chip"):
        world = world_experiment.run_pinch(name, trials, 0)
        mj = mujoco_experiment.run_pinch(name, trials, 0, f_th_n=world.f_th_n)
        total["world"] += world.success
        total["mujoco"] += mj.success
        out[f"mujoco_pinch_success_{name}"] = mj.success
        out[f"mujoco_pinch_world_success_{name}"] = world.success
        out[f"mujoco_pinch_lift_mm_min_{name}"] = round(
            min(t["lifted_mm"] for t in mj.trials), 2)
    out["mujoco_pinch_success"] = total["mujoco"]
    out["mujoco_pinch_world_success"] = total["world"]
    return out


def run_bench() -> dict[str, float]:
    out = sensor_costs()
    gripper_realtime_factor(0.5)  # warm up
    out["mujoco_realtime_factor_full"] = round(
        statistics.median(gripper_realtime_factor() for _ in range(3)), 2)
    out.update(pinch_figures())
    return out


def run() -> dict[str, float]:
    try:
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    except (AttributeError, OSError):
        pass
    return run_bench()


DESCRIPTION = {
    "mujoco_step_us_probe": ("us per MuJoCo step of the probe scene alone (press and slide, "
                             "2 ms), the baseline of the next three", None),
    "mujoco_sensor_us_per_step_wrench": ("us one fingertip adds per 2 ms step: the contact "
                                         "force and where it acts, per HX711 conversion",
                                         None),
    "mujoco_sensor_us_per_step_strain": ("us one fingertip adds per step: the strain model "
                                         "to four HX711 counts at 80 SPS", ("<=", 20.0)),
    "mujoco_sensor_us_per_step_full": ("us one fingertip adds per step: counts and the "
                                       "piezo's 44.1 kHz audio (slip, texture, impacts)",
                                       ("<=", 80.0)),
    "mujoco_realtime_factor_full": ("simulated s per CPU s (one core): gripper on an arm "
                                    "pinching the tofu, two fingertips with audio, "
                                    "everything included",
                                    (">=", 10.0)),
    "mujoco_pinch_success": ("pinch trials held, lifted and unbroken on the MuJoCo gripper "
                             "(tasks/pinch.py unchanged), of 50: 25 tofu + 25 chip", None),
    "mujoco_pinch_world_success": ("the same recipe, thresholds and seeds in today's "
                                   "virtual world, of 50, in the same run", None),
    "mujoco_pinch_success_tofu": ("MuJoCo pinch, tofu (F_th from the demonstration at the "
                                  "paper's 0.5 N), of 25", None),
    "mujoco_pinch_success_chip": ("MuJoCo pinch, potato chip (the paper's 0.1 N), of 25",
                                  None),
    "mujoco_pinch_world_success_tofu": ("today's world, tofu, of 25", None),
    "mujoco_pinch_world_success_chip": ("today's world, chip, of 25", None),
    "mujoco_pinch_lift_mm_min_tofu": ("smallest lift of the tofu's halves when the recipe "
                                      "ends (mm; the arm was told 20)", None),
    "mujoco_pinch_lift_mm_min_chip": ("the same for the chip (mm)", None),
}
