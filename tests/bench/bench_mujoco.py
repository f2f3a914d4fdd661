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

- ``mujoco_force_rmse_n``: a unit's calibrated force model against MuJoCo's contact force
  over a pinch and a slide, beside the same model on a later sweep of its own virtual unit.
- ``mujoco_material_accuracy``: the material classifier trained on today's simulated slides,
  tested on the nail sliding over the MuJoCo plates.
- ``mujoco_pinch_success`` (of 50: the paper's 25 tofu + 25 chip) on the MuJoCo gripper with
  the recipe of ``tasks/pinch.py`` unchanged, beside ``mujoco_pinch_world_success``, the same
  recipe, thresholds and seeds in today's virtual world (``sim/experiment.py``), in this run.
- ``mujoco_cups_success`` (of the paper's 36) on the four-finger hand over five nested cups
  with the recipe of ``tasks/cups.py`` (this hand's settings: the nail's ride over a lip,
  the lip and nail heights), beside ``mujoco_cups_world_success``, today's world's 36 trials
  with the same seeds, in this run.
- ``mujoco_shake_pick_success`` (of the paper's 56) on the four-finger hand over two closed
  boxes whose contents (free bodies) rattle in MuJoCo, with the recipe of
  ``tasks/shake_pick.py`` and a shake classifier trained the same way on shakes recorded on
  MuJoCo (``sim/mujoco/shake_model.py``; today's world's classifier votes 39 of 112 MuJoCo
  boxes right: docs/mujoco.md), beside ``mujoco_shake_pick_world_success``, today's world's
  56 trials with the same seeds and its own classifier; the box votes on the MuJoCo shakes,
  per content, and the contents' wall impacts per shake in both worlds.
- ``mujoco_hold_held_fused`` / ``_none`` (of 20): the slip-reflex hold of ``tasks/hold.py``
  on the sideways gripper, a load of 0.2-0.8 x the object's mass hung on it in 5 ms, with
  the fused reflex and without, beside today's world's same protocol
  (``mujoco_hold_world_held_*``), and the fused reflex hearing the piezo late
  (``mujoco_hold_held_fused_late_audio``: the sensor's default audio blocks).

Single thread, pinned to one core where possible.
"""
from __future__ import annotations

import os
import sys
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from fingertip.sim import experiment as world_experiment
from fingertip.sim.mujoco import FIDELITIES, FingertipSensor
from fingertip.sim.mujoco import experiment as mujoco_experiment
from fingertip.sim.mujoco.cup_trials import run_cups as run_mujoco_cups
from fingertip.sim.mujoco.hold_trials import hold_trial, run_holds
from fingertip.sim.mujoco.shake_trials import run_shake as run_mujoco_shake
from fingertip.sim.physics import BoxShake
from fingertip.sim.world.slip import run_hold_trial, slip_trials
from fingertip.sim.mujoco.drive import press_and_slide
from fingertip.sim.mujoco.drive import run as step_scene
from fingertip.models.force.calibration.evaluate import rmse
from fingertip.models.vibration.classify import VibrationClassifier
from fingertip.models.vibration.features import Recording
from fingertip.models.vibration.material import train_material
from fingertip.sim.dataset import write_vibration
from fingertip.sim.mujoco.gripper import gripper
from fingertip.sim.mujoco.robot import HAND_UNIT, open_gap_mm
from fingertip.sim.mujoco import geometry
from fingertip.sim.mujoco.scenes import NAIL_DOWN, SIDE_DOWN, probe
from fingertip.sim.device.calibration_rig import calibration_sweep
from fingertip.sim.physics import PAPER_SEVEN, VirtualStrainSensor
from fingertip.sim.world.hand import unit_force_model

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


RAIL_HALF_X = 0.002
"""The slide's plate is a 4 mm rail under the band of the fingertip's calibrated face (0-5 mm
below the nail tip): a flat face on a whole plate touches along its length, base included."""
LOADED_N = 0.1
"""Readings with less true force than this are left out of the force errors (as unloaded)."""


def _tared_error(model, readings, t_tare: float = 0.4) -> tuple[np.ndarray, np.ndarray]:
    """Estimates and MuJoCo's lateral forces of the loaded readings, tared on the first
    ``t_tare`` seconds (nothing touches)."""
    tare = np.mean([r.counts for r in readings if r.t < t_tare], axis=0)
    loaded = [r for r in readings if np.hypot(*r.force_n[:2]) > LOADED_N]
    est = model.estimate(np.array([r.counts for r in loaded], float) - tare)
    return np.asarray(est)[:, :2], np.array([r.force_n[:2] for r in loaded])


def _virtual_error(model, readings, t_tare: float = 0.4) -> tuple[np.ndarray, np.ndarray]:
    """The same unit as a virtual fingertip under the same loads (MuJoCo's contact force,
    height and times fed straight to its strain model): its estimates and the truth."""
    sensor = VirtualStrainSensor(HAND_UNIT)
    t = np.array([r.t for r in readings])
    f = np.array([r.force_n for r in readings])
    h = np.array([r.height_mm for r in readings])
    counts = sensor.counts_batch(f[:, :2], h, t, -f[:, 2])
    tare = counts[t < t_tare].mean(axis=0)
    loaded = np.hypot(f[:, 0], f[:, 1]) > LOADED_N
    return np.asarray(model.estimate(counts[loaded] - tare))[:, :2], f[loaded, :2]


def force_rmse() -> dict[str, float]:
    """The unit's calibrated force model against MuJoCo's contact force (pinch, slide), and
    against the virtual fingertip's own truth on a later calibration sweep of that unit."""
    model = unit_force_model(HAND_UNIT)
    sc = gripper(("tofu",))
    brk = sc.info["breakables"]
    pinch = FingertipSensor(sc.model, sc.data, sc.tips["left"], seed=HAND_UNIT, batch=8)
    gap = open_gap_mm(0.015) * 1e-3

    def squeeze(t: float, data) -> None:  # to 1.2 N (below the tofu's 1.5 N) and back
        data.ctrl[2] = -0.096 * min(1.0, t / 0.4)
        u = min(1.0, max(0.0, t - 0.6) / 3.0) - min(1.0, max(0.0, t - 4.6) / 2.0)
        data.ctrl[3] = data.ctrl[4] = gap - 0.001 + 0.005 * u
        brk.update(data)

    step_scene(sc.model, sc.data, [pinch], 7.0, squeeze)
    rs = pinch.readings()
    e1, f1 = _tared_error(model, rs)
    v1, _ = _virtual_error(model, rs)
    sl = probe(("coarse_fabric",), quat=SIDE_DOWN, rail_half_x=RAIL_HALF_X)
    slide = FingertipSensor(sl.model, sl.data, sl.tips["tip"], seed=HAND_UNIT, batch=8,
                            materials=sl.materials)
    press = press_and_slide(press_m=0.004, slide_mm_s=20.0, t_press=1.0, t_slide=1.5, axis=1)
    over_band = geometry().nail_tip_z - 0.0025  # the rail under 0.5-4.5 mm below the nail

    def rail(t: float, data) -> None:
        press(t, data)
        data.ctrl[0] = over_band

    step_scene(sl.model, sl.data, [slide], 4.0, rail)
    rs = slide.readings()
    e2, f2 = _tared_error(model, rs, t_tare=0.3)
    v2, _ = _virtual_error(model, rs, t_tare=0.3)
    sensor = VirtualStrainSensor(HAND_UNIT)
    tare = sensor.counts_batch(np.zeros((16, 2)), 0.0, np.arange(1, 17) / 80).mean(axis=0)
    sw = calibration_sweep(sensor, seed=7, t0_us=1_000_000)
    truth = np.column_stack([sw.fx, sw.fy])
    keep = np.hypot(sw.fx, sw.fy) > LOADED_N
    sweep = rmse(model.estimate(sw.counts[keep] - tare), truth[keep])
    both = rmse(np.vstack([e1, e2]), np.vstack([f1, f2]))
    own = rmse(np.vstack([v1, v2]), np.vstack([f1, f2]))
    return {"mujoco_force_rmse_n": round(both, 4),
            "mujoco_force_rmse_pinch_n": round(rmse(e1, f1), 4),
            "mujoco_force_rmse_slide_n": round(rmse(e2, f2), 4),
            "mujoco_force_rmse_virtual_n": round(own, 4),
            "mujoco_force_rmse_sweep_n": round(sweep, 4),
            "mujoco_force_rmse_ratio": round(both / own, 3)}


MATERIAL_SLIDES = 5
"""MuJoCo slides per material (the nail over its plate, speed 10-30 mm/s, 0.5-2 N)."""


def _mujoco_slide(name: str, speed_mm_s: float, press_m: float, seed: int) -> np.ndarray:
    """The piezo of the nail sliding over plate ``name`` (the 1.6 s of steady sliding)."""
    sc = probe((name,), quat=NAIL_DOWN)
    s = FingertipSensor(sc.model, sc.data, sc.tips["tip"], fidelity="full", seed=seed,
                        materials=sc.materials)
    step_scene(sc.model, sc.data, [s], 2.8,
               press_and_slide(press_m=press_m, slide_mm_s=speed_mm_s, t_press=0.6,
                               t_slide=1.0, axis=1))
    return np.concatenate([b.samples for b in s.audio()
                           if b.t0 >= 1.2 and b.t0 + len(b.samples) / b.fs <= 2.8])


def material_accuracy() -> dict[str, float]:
    """The material classifier trained on today's simulated slides (100 per material, as
    bench_classify does), tested on slides over the MuJoCo plates: per window, and one
    majority vote per slide."""
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        write_vibration(folder / "data", kind="materials", recordings_per_class=100, seed=5)
        train_material(folder / "data", folder, plot=False, epochs=150, models=("mlp",))
        clf = VibrationClassifier(folder / "material.onnx")
        right = windows = votes = slides = 0
        for name in PAPER_SEVEN:
            for k in range(MATERIAL_SLIDES):
                x = _mujoco_slide(name, float(rng.uniform(10, 30)),
                                  float(rng.uniform(0.001, 0.004)), k)
                labels = [p.label for p in clf.classify(Recording(x.astype(np.float64),
                                                                  44100)).predictions]
                right += sum(label == name for label in labels)
                windows += len(labels)
                votes += max(set(labels), key=labels.count) == name
                slides += 1
    return {"mujoco_material_accuracy": round(right / windows, 4),
            "mujoco_material_vote_accuracy": round(votes / slides, 4)}


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


def cups_figures(trials: int = 36) -> dict[str, float]:
    """The paper's cup protocol in both worlds, the same seeds (each world draws its stack,
    speed and target from them)."""
    mj = run_mujoco_cups(trials, 0)
    world = world_experiment.run_cups(trials, 0)
    s = mj.summary()
    errors = [t["rim_height_error_mm"] for t in mj.trials if t["rim_height_error_mm"] is not None]
    out = {"mujoco_cups_success": mj.success, "mujoco_cups_counted": s["counted"],
           "mujoco_cups_lifted": s["lifted"],
           "mujoco_cups_rim_error_mm_max": round(max(errors), 3) if errors else float("nan"),
           "mujoco_cups_world_success": world.success}
    for mode, n in s["failure_modes"].items():
        out[f"mujoco_cups_failed_{mode.replace(' ', '_').replace('(', '').replace(')', '')}"] = n
    return out


def shake_figures(trials: int = 56) -> dict[str, float]:
    """The paper's shake-and-pick in both worlds, the same seeds and targets."""
    mj = run_mujoco_shake(trials, 0, progress=lambda m: print(m, file=sys.stderr, flush=True))
    world = world_experiment.run_shake(trials, 0)
    s = mj.summary()
    out: dict[str, float] = {"mujoco_shake_pick_success": mj.success,
                             "mujoco_shake_pick_world_success": world.success,
                             "mujoco_shake_votes_correct": s["box_votes_correct"],
                             "mujoco_shake_votes": s["box_votes"]}
    boxes = [b for t in mj.trials for b in t["boxes"] if b["vote"] is not None]
    wboxes = [b for t in world.trials for b in t["boxes"] if b["vote"] is not None]
    for content in ("screws", "rubber_bands"):
        mine = [b for b in boxes if b["content"] == content]
        out[f"mujoco_shake_{content}_voted_right"] = sum(b["vote"] == content for b in mine)
        out[f"mujoco_shake_{content}_voted_empty"] = sum(b["vote"] == "empty" for b in mine)
        out[f"mujoco_shake_{content}_boxes"] = len(mine)
        out[f"mujoco_shake_{content}_window_accuracy"] = round(float(np.mean(
            [b["shares"].get(content, 0.0) for b in mine])), 4) if mine else float("nan")
        out[f"mujoco_shake_{content}_impacts_median"] = float(np.median(
            [b["impacts"] for b in mine])) if mine else float("nan")
        # The world's scripted impacts for the same fills (its default shake).
        theirs = [b for b in wboxes if b["content"] == content]
        out[f"mujoco_shake_world_{content}_voted_right"] = sum(b["vote"] == content
                                                               for b in theirs)
        out[f"mujoco_shake_world_{content}_impacts_median"] = float(np.median(
            [len(BoxShake(content, items=b["items"]).events()["impact_times_s"])
             for b in theirs])) if theirs else float("nan")
    # The modes described below always reported, 0 when none: a run keeps earlier keys it
    # did not write, so a mode that vanished would otherwise keep its old count.
    for mode, n in (dict.fromkeys(("arm blocked", "not opened"), 0)
                    | s["failure_modes"]).items():
        out[f"mujoco_shake_failed_{mode.replace(' ', '_')}"] = n
    return out


HOLD_TRIALS = 20


def hold_figures(trials: int = HOLD_TRIALS) -> dict[str, float]:
    """Holds that kept the object (slid < 5 mm), MuJoCo and today's world, same seeds."""
    mj = run_holds(trials, 0)
    out: dict[str, float] = {}
    for reflex, rs in mj.items():
        out[f"mujoco_hold_held_{reflex}"] = sum(r["held"] for r in rs)
        out[f"mujoco_hold_slid_mm_median_{reflex}"] = round(
            float(np.median([r["slid_mm"] for r in rs])), 2)
    late = [hold_trial(s, "fused", audio={}) for s in range(trials)]
    out["mujoco_hold_held_fused_late_audio"] = sum(r["held"] for r in late)
    for reflex in ("none", "fused"):
        out[f"mujoco_hold_world_held_{reflex}"] = sum(
            run_hold_trial(tr, reflex)["held"] for tr in slip_trials(trials, 0))
    return out


def run_bench() -> dict[str, float]:
    out = sensor_costs()
    out.update(force_rmse())
    out.update(material_accuracy())
    gripper_realtime_factor(0.5)  # warm up
    out["mujoco_realtime_factor_full"] = round(
        statistics.median(gripper_realtime_factor() for _ in range(3)), 2)
    out.update(pinch_figures())
    out.update(cups_figures())
    out.update(hold_figures())
    out.update(shake_figures())
    return out


PARTS = {"shake": shake_figures, "hold": hold_figures}


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
    "mujoco_force_rmse_n": ("force RMSE (N): sqrt(mean |(Fx, Fy) estimated - (Fx, Fy) "
                            "MuJoCo|^2) of unit 100's force model (fitted on its own "
                            "simulated sweep) on its counts from FingertipSensor (strain, "
                            "every error source on, tared without contact) against MuJoCo's "
                            "contact force averaged per conversion, pinch (0-1.2 N) and slide "
                            "(2 N, coarse fabric), both on the calibrated side 0-5 mm below "
                            "the nail tip, conversions above 0.1 N; docs/mujoco.md", None),
    "mujoco_force_rmse_pinch_n": ("the same, the pinch alone", None),
    "mujoco_force_rmse_slide_n": ("the same, the slide alone", None),
    "mujoco_force_rmse_virtual_n": ("the virtual fingertip's own figure: the same unit fed "
                                    "the same loads (MuJoCo's force, height, times) straight "
                                    "into its strain model, the same model", None),
    "mujoco_force_rmse_sweep_n": ("the same model on a later calibration sweep of its unit "
                                  "(the paper's protocol, every error source)", None),
    "mujoco_force_rmse_ratio": ("mujoco_force_rmse_n over mujoco_force_rmse_virtual_n (the "
                                "virtual fingertip's own figure under the same loads)",
                                ("<=", 1.1)),
    "mujoco_material_accuracy": ("the material classifier trained on today's simulated slides "
                                 "(100 per material), per window on the nail sliding over "
                                 "the MuJoCo plates (5 slides per material, 10-30 mm/s, "
                                 "0.5-2 N)", (">=", 0.95)),
    "mujoco_material_vote_accuracy": ("the same, one majority vote per slide", None),
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
    "mujoco_cups_success": ("cup trials counted and lifted on the MuJoCo four-finger hand "
                            "over five nested cups (tasks/cups.py), of the paper's 36",
                            None),
    "mujoco_cups_counted": ("of those 36: the rims counted equal the rims the nail passed",
                            None),
    "mujoco_cups_lifted": ("of those 36: the cups lifted 10 mm or more equal the target",
                           None),
    "mujoco_cups_rim_error_mm_max": ("largest distance (mm) of a counted rim's height (the "
                                     "arm's logged z at its onset) from the true lip top",
                                     None),
    "mujoco_cups_world_success": ("the same recipe and seeds in today's virtual world, of "
                                  "36, in the same run", None),
    "mujoco_shake_pick_success": ("shake-and-pick trials opening the box with the requested "
                                  "content on the MuJoCo four-finger hand (contents free "
                                  "bodies rattling in closed boxes; tasks/shake_pick.py, "
                                  "the shake classifier trained on MuJoCo shakes), of the "
                                  "paper's 56",
                                  None),
    "mujoco_shake_pick_world_success": ("the same recipe and seeds in today's virtual "
                                        "world with its own classifier, of 56, in the same "
                                        "run", None),
    "mujoco_shake_votes_correct": ("MuJoCo box votes (majority of the 10 Hz predictions "
                                   "over a shake) naming the box's content", None),
    "mujoco_shake_votes": ("MuJoCo boxes voted on (two per trial that read both)", None),
    "mujoco_shake_screws_voted_right": ("MuJoCo screw boxes voted screws", None),
    "mujoco_shake_screws_voted_empty": ("MuJoCo screw boxes voted empty", None),
    "mujoco_shake_screws_boxes": ("MuJoCo screw boxes voted on", None),
    "mujoco_shake_screws_window_accuracy": ("mean share of a MuJoCo screw box's 10 Hz "
                                            "predictions that say screws", None),
    "mujoco_shake_screws_impacts_median": ("median impacts of the screws on their box's "
                                           "walls per shake in MuJoCo (new item-wall "
                                           "contacts faster than 2 mm/s)", None),
    "mujoco_shake_world_screws_voted_right": ("today's world's screw boxes voted screws",
                                              None),
    "mujoco_shake_world_screws_impacts_median": ("median scripted impacts per shake of the "
                                                 "same screw boxes in today's world", None),
    "mujoco_shake_rubber_bands_voted_right": ("MuJoCo rubber-band boxes voted rubber bands",
                                              None),
    "mujoco_shake_rubber_bands_voted_empty": ("MuJoCo rubber-band boxes voted empty", None),
    "mujoco_shake_rubber_bands_boxes": ("MuJoCo rubber-band boxes voted on", None),
    "mujoco_shake_rubber_bands_window_accuracy": ("mean share of a MuJoCo rubber-band box's "
                                                  "predictions that say rubber bands", None),
    "mujoco_shake_rubber_bands_impacts_median": ("median impacts of the rubber bands on "
                                                 "their box's walls per shake in MuJoCo",
                                                 None),
    "mujoco_shake_world_rubber_bands_voted_right": ("today's world's rubber-band boxes voted "
                                                    "rubber bands", None),
    "mujoco_shake_world_rubber_bands_impacts_median": ("median scripted impacts per shake of "
                                                       "the same rubber-band boxes in today's "
                                                       "world", None),
    "mujoco_shake_failed_arm_blocked": ("MuJoCo shake trials in which the arm stopped on a "
                                        "box that a swing in the grip had moved (a nail on "
                                        "its roof)", None),
    "mujoco_shake_failed_not_opened": ("MuJoCo shake trials in which the chosen box was "
                                       "right but the other box's tray was out too (it slid "
                                       "while the box swung)", None),
    "mujoco_hold_held_fused": ("MuJoCo holds that kept the object (slid < 5 mm) with the "
                               "fused slip reflex (tasks/hold.py, Coulomb law), of 20: five "
                               "objects in turn, a sudden load of 0.2-0.8 x the mass", None),
    "mujoco_hold_held_none": ("the same without a reflex (the paper's hold), of 20", None),
    "mujoco_hold_held_fused_late_audio": ("the fused reflex hearing the piezo as the "
                                          "sensor's defaults deliver it (4096-sample blocks "
                                          "rendered 20 ms behind: up to 113 ms late) instead "
                                          "of as a low-latency capture (REFLEX_AUDIO), of 20",
                                          None),
    "mujoco_hold_slid_mm_median_fused": ("median slide of the object down the fingertips "
                                         "(mm), fused reflex", None),
    "mujoco_hold_slid_mm_median_none": ("the same without a reflex (15 mm: back on the "
                                        "table)", None),
    "mujoco_hold_world_held_fused": ("today's world, the same protocol and seeds, fused "
                                     "reflex, of 20", None),
    "mujoco_hold_world_held_none": ("today's world, no reflex, of 20", None),
    "mujoco_cups_failed_not_separated": ("MuJoCo cup trials that lifted more cups than the "
                                         "target (a fit held through the strokes)", None),
}
