"""How fast can the pinch close? The pinch recipe itself, closing the simulated hand at each
speed, per contact detector.

Each trial is :func:`fingertip.tasks.pinch.pinch` (the recipe ``fingertip experiment
pinch`` runs) with ``approach_speed_mm_s`` set: every finger closes at that speed until its
contact detector reports a touch, stops, and the recipe regulates to the paper's pinch force
(0.5 N tofu, 0.1 N chip: ``PINCH_OBJECTS``) with its fine steps, then lifts 20 mm. The hand
is :class:`.world.approach_hand.ApproachHand` on the pinch trials' world
(:func:`~fingertip.sim.world.hand.make_world`, seed = trial): force frames at 15 Hz (the
paper's controller) or 80 Hz, the piezos for the fused detector, and the world's crushing.
The contact source is :class:`~fingertip.events.contact_set.ContactSet`: force frames alone
(``force15``, ``force80``) or fused piezo + force at 80 Hz (``fused``).

Each finger starts ``PRE_S`` of travel (at the trial's speed) farther than the placement's
0.3-1.3 mm, so it is at speed, and past the 80 ms in which the fused detector ignores the
piezo after a move starts (its own motor spinning up), before it touches. Success is the
experiment's: held, lifted 20 mm, unbroken.
"""
from __future__ import annotations

import logging
from collections.abc import Callable, Iterable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from functools import partial

from ..events.contact_set import ContactSet
from .experiment import PINCH_OBJECTS
from ..tasks.pinch import PinchConfig, pinch
from .world.hand import FINGERS, make_world
from .world.approach_hand import ApproachHand

log = logging.getLogger(__name__)

MODES = {"force15": ("force", 15.0), "force80": ("force", 80.0), "fused": ("fused", 80.0)}
PRE_S = 0.15
"""Extra approach before the surface, in seconds of travel at the trial's speed."""
OBJECTS = ("tofu", "chip")


@dataclass
class PinchSpeedTrial:
    obj: str
    speed_mm_s: float
    seed: int
    mode: str
    success: bool
    outcome: str
    broken: bool
    peak_true_n: float
    detect_ms: list[float]
    """Per finger that touched before its stop: from the true touch to the recipe's stop
    command (simulated time: detection and the recipe's reaction)."""
    sources: list[str]


def pinch_trial(obj: str, speed_mm_s: float, seed: int, mode: str) -> PinchSpeedTrial:
    """One pinch of ``obj`` (placement ``seed``) approaching at ``speed_mm_s``."""
    if obj not in PINCH_OBJECTS:
        raise ValueError(f"object must be one of {sorted(PINCH_OBJECTS)}, not {obj!r}")
    if mode not in MODES:
        raise ValueError(f"mode must be one of {sorted(MODES)}, not {mode!r}")
    spec, f_th, step = PINCH_OBJECTS[obj]
    kind, rate = MODES[mode]
    world, hand, arm = make_world(
        spec, seed, hand_factory=partial(ApproachHand, rate_hz=rate, seed=seed))
    for f in FINGERS:
        world.obj.gaps_mm[f] += speed_mm_s * PRE_S
    contact = ContactSet(hand.fingers, kind, fs=hand.fs if kind == "fused" else None)
    cfg = PinchConfig(f_th, step_mm=step, approach_speed_mm_s=speed_mm_s)
    r = pinch(hand, arm, cfg, contact)
    broken = world.obj.broken
    ok = r.ok and not broken and world.obj.lifted_mm >= cfg.lift_mm - 1e-6
    outcome = "broken" if broken else r.outcome.value if not r.ok else \
        "ok" if ok else "dropped"
    det, src = [], []
    for f, ev in r.contacts.items():
        if f in hand.contact_s and f in hand.stop_s and hand.stop_s[f] >= hand.contact_s[f]:
            det.append((hand.stop_s[f] - hand.contact_s[f]) * 1e3)
        src.append(ev.source)
    return PinchSpeedTrial(obj, speed_mm_s, seed, mode, ok, outcome, broken,
                           world.obj.peak_force_n, det, src)


Curve = dict[float, dict[str, int]]


def _point(args: tuple[str, float, int, int]) -> tuple[str, float, dict[str, int]]:
    mode, v, seed, trials = args
    return mode, v, {o: sum(pinch_trial(o, v, s, mode).success
                            for s in range(seed, seed + trials)) for o in OBJECTS}


def sweep(speeds: Iterable[float], trials: int = 25, seed: int = 0,
          modes: Iterable[str] = tuple(MODES), workers: int = 1,
          progress: Callable[[str], None] | None = None) -> dict[str, Curve]:
    """mode -> speed -> object -> successes of ``trials`` (seeds ``seed``..). Each mode
    runs its speeds in increasing order, ``workers`` at a time, and stops after the first
    batch in which some object never survived (faster only overshoots more)."""
    speeds = sorted(float(v) for v in speeds)
    if not speeds or speeds[0] <= 0:
        raise ValueError("speeds must be > 0")
    out: dict[str, Curve] = {}
    with ProcessPoolExecutor(workers) if workers > 1 else _Serial() as pool:
        for mode in modes:
            out[mode] = {}
            for a in range(0, len(speeds), workers):
                batch = [(mode, v, seed, trials) for v in speeds[a:a + workers]]
                for m, v, counts in pool.map(_point, batch):
                    out[m][v] = counts
                    if progress is not None:
                        progress(f"{m} {v:g} mm/s: {counts}")
                if any(min(out[mode][v].values()) == 0 for v in speeds[a:a + workers]):
                    break
    return out


class _Serial:
    def __enter__(self) -> _Serial:
        return self

    def __exit__(self, *exc) -> None:
        return None

    @staticmethod
    def map(fn, items):
        return map(fn, items)


def max_safe_speed(curve: Curve, trials: int = 25) -> float:
    """Highest speed at which every object succeeded in every trial, with every slower
    speed also safe (0 if none)."""
    best = 0.0
    for v in sorted(curve):
        if all(n == trials for n in curve[v].values()):
            best = v
        else:
            break
    return best


def plot(result: dict[str, Curve], path, trials: int = 25):
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
    ax.set_title(f"Pinch recipe on the simulated hand: tofu + chip, {trials} trials each")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def table(result: dict[str, Curve], trials: int = 25) -> str:
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
