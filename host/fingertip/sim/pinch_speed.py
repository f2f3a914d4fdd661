"""How fast can the pinch close? Closing speed against success, per contact detector.

The pinch closes in two phases: each finger approaches at the closing speed v until its
contact detector reports contact, then stops (``COMMAND_S`` for the command to reach the
finger's motor, then braking at ``BRAKE_MM_S2``) and regulates to ``F_th`` with the paper's
fine steps (:data:`fingertip.sim.experiment.PINCH_OBJECTS`: a step per force frame). The
object is the pinch trials' (:func:`fingertip.sim.world.hand.make_world` placement: each
finger touches after 0.3-1.3 mm, on the skin's side 1-4 mm below the nail); a finger whose
true force ever exceeds the object's crush force breaks it.

The detection time of each finger comes from the contact detectors run on its own
simulated signals (:mod:`.physics.touch`: the make transient, the finger's motor noise,
speech at 65 dB, the force frames through a virtual strain unit), exactly as in the
latency evaluation (:mod:`.reflex_eval`); until the detection the finger moves at v, so the
force ramps at k v. Peak force = k x (v x (detection - contact + COMMAND_S) + v^2 / (2
BRAKE_MM_S2)), or the regulation's F_th plus one fine step if that is higher.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .experiment import PINCH_OBJECTS
from .world.hand import FINGERS
from .physics.touch import Session, Touch
from .reflex_eval import run_session

COMMAND_S = 0.002
"""From the host's decision to the finger's motor (a serial command; assumed)."""
BRAKE_MM_S2 = 5000.0
"""Braking of a small geared finger (assumed: 80 mm/s stops within 16 ms)."""
F_TH_N = {"tofu": 0.5, "chip": 0.1}
"""The pinch force (the paper's): the demonstrations estimate about this."""
MODES = {"force15": ("force", 15.0), "force80": ("force", 80.0), "fused": ("fused", 80.0)}


@dataclass
class PinchSpeedTrial:
    obj: str
    speed_mm_s: float
    seed: int
    mode: str
    peaks_n: list[float]
    close_s: float
    """Time from the start of the approach to every finger at F_th."""

    @property
    def success(self) -> bool:
        return max(self.peaks_n) < PINCH_OBJECTS[self.obj][0].crush_n


def placement(seed: int) -> tuple[dict[str, float], dict[str, float], dict[str, float]]:
    """Gaps, angles, heights as :func:`~fingertip.sim.world.hand.make_world` draws them."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, 8]))
    gaps = {f: float(rng.uniform(0.3, 1.3)) for f in FINGERS}
    angles = {f: float(rng.uniform(-20, 20)) for f in FINGERS}
    heights = {f: float(rng.uniform(1.0, 4.0)) for f in FINGERS}
    return gaps, angles, heights


def pinch_trial(obj: str, speed_mm_s: float, seed: int, mode: str,
                wall_clock: bool = False) -> PinchSpeedTrial:
    spec, _, step_mm = PINCH_OBJECTS[obj]
    k = spec.stiffness_n_per_mm
    f_th = F_TH_N[obj]
    kind, rate = MODES[mode]
    gaps, angles, heights = placement(seed)
    phase = np.random.default_rng(np.random.SeedSequence([seed, 0x9A5E])).uniform(0, 1, 4)
    peaks, ends = [], []
    for i, f in enumerate(FINGERS):
        # The approach starts 0.25 s before contact; the force frames' phase at the
        # contact is the trial's (the fingers touch at different moments).
        tc = 0.25 + float(phase[i]) / 15.0
        # The touch's force ramps at k v until well past any detection; its release lies
        # beyond the session, so only the make matters.
        touch = Touch(tc, speed_mm_s, k, 10.0 * spec.crush_n + 1.0, hold_s=10.0,
                      height_mm=heights[f], angle_deg=angles[f])
        horizon = min(1.5, 0.15 + 0.1 / (k * speed_mm_s))   # past a force-only detection
        session = Session(tc + horizon, [touch], seed * 16 + i, speech_db=65.0)
        res = run_session(session, kind, rate, wall_clock=wall_clock)
        late = res.latency_s[0] if res.latency_s else horizon
        travel = speed_mm_s * (late + COMMAND_S) + speed_mm_s ** 2 / (2 * BRAKE_MM_S2)
        peak = k * travel
        # Regulation to F_th with the fine step, one step per force frame (at ``rate``).
        steps = max(0, math.ceil((f_th - peak) / (k * step_mm)))
        if peak < f_th:
            peak = max(peak, f_th) + k * step_mm * (1 if steps else 0)
        peaks.append(peak)
        ends.append(gaps[f] / speed_mm_s + late + COMMAND_S + steps / rate)
    return PinchSpeedTrial(obj, speed_mm_s, seed, mode, peaks, max(ends))


def sweep(speeds: list[float], trials: int = 25, seed: int = 0,
          modes: tuple[str, ...] = tuple(MODES)) -> dict[str, dict[float, dict[str, int]]]:
    """mode -> speed -> object -> successes of ``trials`` (seeds ``seed``..). A mode's
    sweep stops after the first speed at which some object never survives (faster only
    breaks more: the overshoot grows with the speed)."""
    out: dict[str, dict[float, dict[str, int]]] = {}
    for mode in modes:
        out[mode] = {}
        for v in sorted(speeds):
            out[mode][v] = {o: sum(pinch_trial(o, v, s, mode).success
                                   for s in range(seed, seed + trials))
                            for o in F_TH_N}
            if min(out[mode][v].values()) == 0:
                break
    return out


def max_safe_speed(curve: dict[float, dict[str, int]], trials: int = 25) -> float:
    """Highest speed at which every object succeeded in every trial, with every slower
    speed also safe (0 if none)."""
    best = 0.0
    for v in sorted(curve):
        if all(n == trials for n in curve[v].values()):
            best = v
        else:
            break
    return best


def plot(result: dict[str, dict[float, dict[str, int]]], path, trials: int = 25):
    """PNG of success (both objects, of 2 x trials) against closing speed, per detector."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    names = {"force15": "force only, 15 Hz", "force80": "force only, 80 Hz",
             "fused": "fused piezo + force"}
    for mode, curve in result.items():
        v = sorted(curve)            # stops at the first speed that always breaks
        ax.semilogx(v, [sum(curve[s].values()) for s in v], "o-", label=names.get(mode, mode))
    ax.axhline(2 * trials, color="grey", lw=0.8, ls=":")
    ax.set_xlabel("closing speed before contact (mm/s)")
    ax.set_ylabel(f"pinches intact and held (of {2 * trials})")
    ax.set_title("Simulated pinch: tofu + potato chip, 25 trials each")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def table(result: dict[str, dict[float, dict[str, int]]], trials: int = 25) -> str:
    speeds = sorted({v for curve in result.values() for v in curve})
    lines = ["| closing speed (mm/s) | " + " | ".join(result) + " |",
             "|---|" + "---|" * len(result)]
    for v in speeds:
        cells = [f"{result[m][v]['tofu']}/{trials} tofu, {result[m][v]['chip']}/{trials} chip"
                 if v in result[m] else "not run (slower already broke)" for m in result]
        lines.append(f"| {v:g} | " + " | ".join(cells) + " |")
    lines.append("| highest 25/25-safe | " + " | ".join(
        f"{max_safe_speed(result[m], trials):g} mm/s" for m in result) + " |")
    return "\n".join(lines) + "\n"
