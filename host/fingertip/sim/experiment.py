"""The paper's manipulation protocols on the simulated hand, with per-trial variation.

:func:`run_pinch`, :func:`run_cups` and :func:`run_shake` run trials with seeds ``seed`` ..
``seed + trials - 1`` (each seed varies the world as its ``make_*_world`` says), judge each
trial from the world's ground truth (which the recipes never see) and return a result whose
``to_dict()`` is JSON-ready and whose ``table()`` is the paper's form. Failure modes are
counted by name, never dropped.
"""
from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..tasks.cups import CupConfig, unstack
from ..tasks.pinch import PinchConfig, pinch
from ..tasks.shake_pick import ShakeConfig, shake_and_pick
from .world.boxes import BOX_X_MM, MATERIALS, make_box_world, shake_model_path
from .world.cups import approach_height, make_cup_world
from .world.demonstration import demonstrate
from .world.hand import CHIP, TOFU, ObjectSpec, make_world

log = logging.getLogger(__name__)

Progress = Callable[[str], None]
"""Called once per finished trial with a short description of it."""

PINCH_OBJECTS: dict[str, tuple[ObjectSpec, float, float]] = {
    "tofu": (TOFU, 0.5, 0.05), "chip": (CHIP, 0.1, 0.005)}
"""Object -> (spec, the paper's pinch force (the demonstrator's firmness), closing step in
mm)."""
DEMO_SEED_OFFSET = 100_000
"""The demonstration's placement seed is the trials' first seed plus this: never a trial."""
BOX_GRIP_Z_MM = 40.0


def _pct(a: np.ndarray, q: float) -> float:
    return float(np.percentile(a, q)) if len(a) else float("nan")


def _modes(trials: list[dict]) -> dict[str, int]:
    return dict(Counter(t["failure"] for t in trials if t["failure"]))


# --- pinch ----------------------------------------------------------------------------------

@dataclass
class PinchTrials:
    object: str
    f_th_n: float
    """The threshold the controller used (from the demonstration unless given)."""
    seed: int
    demo_firmness_n: float | None = None
    """The demonstrator's true grip force per finger (None: F_th was given, no demo)."""
    trials: list[dict] = field(default_factory=list)
    latencies_ms: list[float] = field(default_factory=list)

    @property
    def success(self) -> int:
        return sum(t["success"] for t in self.trials)

    def summary(self) -> dict:
        lat = np.asarray(self.latencies_ms)
        return {"object": self.object, "f_th_n": self.f_th_n,
                "demo_firmness_n": self.demo_firmness_n, "trials": len(self.trials),
                "success": self.success, "broken": sum(t["broken"] for t in self.trials),
                "dropped": sum(t["dropped"] for t in self.trials),
                "max_force_n": max((t["peak_true_n"] for t in self.trials), default=0.0),
                "latency_p50_ms": _pct(lat, 50), "latency_p99_ms": _pct(lat, 99),
                "failure_modes": _modes(self.trials)}

    def to_dict(self) -> dict:
        return {"protocol": "pinch", "seed": self.seed, "summary": self.summary(),
                "trials": self.trials}


def run_pinch(obj: str = "tofu", trials: int = 25, seed: int = 0,
              progress: Progress | None = None, f_th_n: float | None = None) -> PinchTrials:
    """The paper's pinch: one demonstration at the paper's force gives F_th (unless
    ``f_th_n`` is given), then each trial closes to F_th and lifts 20 mm; success = held,
    lifted, unbroken."""
    spec, firmness, step = PINCH_OBJECTS[obj]
    if f_th_n is None:
        demo = demonstrate(spec, firmness, seed=seed + DEMO_SEED_OFFSET, step_mm=step)
        if demo.broken:
            raise RuntimeError(f"the {obj} broke during its demonstration")
        out = PinchTrials(obj, demo.f_th_n, seed, demo_firmness_n=firmness)
    else:
        out = PinchTrials(obj, f_th_n, seed)
    f_th = out.f_th_n
    for s in range(seed, seed + trials):
        world, hand, arm = make_world(spec, s)
        cfg = PinchConfig(f_th, step_mm=step)
        r = pinch(hand, arm, cfg)
        broken = world.obj.broken
        dropped = r.ok and not broken and world.obj.lifted_mm < cfg.lift_mm - 1e-6
        failure = None if r.ok else r.outcome.value
        if failure is None and broken:
            failure = "broken"
        elif failure is None and dropped:
            failure = "dropped"
        out.trials.append({"seed": s, "success": failure is None, "outcome": r.outcome.value,
                           "broken": broken, "dropped": dropped, "failure": failure,
                           "peak_true_n": world.obj.peak_force_n,
                           "lifted_mm": world.obj.lifted_mm})
        out.latencies_ms += r.latencies_ms
        if progress is not None:
            progress(f"{obj} seed {s}: {failure or 'ok'}")
    return out


def pinch_table(results: list[PinchTrials]) -> str:
    lines = ["| object | demonstrated at | F_th (estimated) | trials | success | broken | "
             "dropped | max true force | loop latency p50 / p99 |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        s = r.summary()
        demo = "-" if s["demo_firmness_n"] is None else f"{s['demo_firmness_n']:g} N"
        lines.append(f"| {s['object']} | {demo} | {s['f_th_n']:.3f} N | {s['trials']} | "
                     f"{s['success']}/{s['trials']} | {s['broken']} | {s['dropped']} | "
                     f"{s['max_force_n']:.2f} N | {s['latency_p50_ms']:.2f} / "
                     f"{s['latency_p99_ms']:.2f} ms |")
    lines += _mode_lines({r.object: r.summary()["failure_modes"] for r in results})
    return "\n".join(lines) + "\n"


def _mode_lines(modes: dict[str, dict[str, int]]) -> list[str]:
    out = []
    for name, m in modes.items():
        text = ", ".join(f"{k}: {v}" for k, v in sorted(m.items())) or "none"
        out.append(f"\nfailure modes ({name}): {text}" if name else f"\nfailure modes: {text}")
    return out


# --- cups -----------------------------------------------------------------------------------

@dataclass
class CupTrials:
    seed: int
    config: dict
    trials: list[dict] = field(default_factory=list)

    @property
    def success(self) -> int:
        return sum(t["success"] for t in self.trials)

    def summary(self) -> dict:
        per = {}
        for k in (1, 2, 3):
            ts = [t for t in self.trials if t["target"] == k]
            per[str(k)] = {"trials": len(ts), "success": sum(t["success"] for t in ts)}
        return {"trials": len(self.trials),
                "counted": sum(t["counted"] for t in self.trials),
                "lifted": sum(t["lifted_ok"] for t in self.trials),
                "success": self.success, "per_target": per,
                "failure_modes": _modes(self.trials)}

    def to_dict(self) -> dict:
        return {"protocol": "cups", "seed": self.seed, "config": self.config,
                "summary": self.summary(), "trials": self.trials}


def run_cups(trials: int = 36, seed: int = 0, progress: Progress | None = None,
             **config) -> CupTrials:
    """The paper's cup trials: a 21 mm slide over three rims, a random target of 1-3 cups.
    ``config``: :class:`CupConfig` fields for every trial (e.g. a wrong ``k``); the slide
    speed (6-15 mm/s) and the target are drawn per trial unless given."""
    out = CupTrials(seed, {k: v for k, v in config.items()})
    for s in range(seed, seed + trials):
        world, hand, arm = make_cup_world(s)
        rng = np.random.default_rng(np.random.SeedSequence([s, 0x7A6]))
        target = int(rng.integers(1, 4))
        speed = float(rng.uniform(6.0, 15.0))
        cfg = CupConfig(**{"slide_speed_mm_s": speed, **config})
        arm.move_to(0.0, 0.0, approach_height(world))
        r = unstack(hand, arm, target, cfg)
        passed = world.slides[0]["rims_passed"] if world.slides else 0
        counted = r.rims.count == passed
        lifted = world.lifted_cups()
        failure = r.failure
        if failure is None:
            if not counted:
                failure = "miscounted"
            elif world.on_rim:
                failure = "grasp on a rim"
            elif world.clinging and lifted == target + 1:
                failure = "not separated"
            elif lifted != target:
                failure = "wrong number lifted"
        elif failure == "too few rims" and not counted:
            failure = "miscounted (too few rims)"
        truth = world.stack.rims_mm() if world.stack else np.zeros(0)
        err = [float(np.min(np.abs(truth - h))) for h in r.rims.heights_mm]
        out.trials.append({
            "seed": s, "target": target, "speed_mm_s": round(speed, 3),
            "rims_found": r.rims.count, "rims_passed": passed, "counted": counted,
            "rim_height_error_mm": round(max(err), 3) if err else None,
            "grasp_z_mm": r.grasp_z_mm, "lifted": lifted, "lifted_ok": lifted == target,
            "strokes": r.strokes, "success": failure is None, "failure": failure})
        if progress is not None:
            progress(f"cups seed {s}: {failure or 'ok'}")
    return out


def cups_table(r: CupTrials) -> str:
    s = r.summary()
    n = s["trials"]
    lines = ["| metric | result |", "|---|---|",
             f"| trials | {n} |",
             f"| counted correctly | {s['counted']}/{n} |",
             f"| lifted the requested number | {s['lifted']}/{n} |",
             f"| counted and lifted (the paper's 36/36) | {s['success']}/{n} |"]
    for k, v in s["per_target"].items():
        lines.append(f"| target {k} cup{'s' if k != '1' else ''} | "
                     f"{v['success']}/{v['trials']} |")
    lines += _mode_lines({"": s["failure_modes"]})
    return "\n".join(lines) + "\n"


# --- shake and pick -------------------------------------------------------------------------

@dataclass
class ShakeTrials:
    seed: int
    trials: list[dict] = field(default_factory=list)
    model: str = ""

    @property
    def success(self) -> int:
        return sum(t["success"] for t in self.trials)

    def summary(self) -> dict:
        per = {}
        for m in MATERIALS:
            ts = [t for t in self.trials if t["target"] == m]
            per[m] = {"trials": len(ts), "success": sum(t["success"] for t in ts)}
        boxes = [b for t in self.trials for b in t["boxes"] if b["vote"] is not None]
        return {"trials": len(self.trials), "success": self.success, "per_target": per,
                "box_votes_correct": sum(b["vote"] == b["content"] for b in boxes),
                "box_votes": len(boxes), "failure_modes": _modes(self.trials)}

    def to_dict(self) -> dict:
        return {"protocol": "shake", "seed": self.seed, "model": self.model,
                "summary": self.summary(), "trials": self.trials}


def run_shake(trials: int = 56, seed: int = 0, progress: Progress | None = None,
              config: ShakeConfig | None = None) -> ShakeTrials:
    """Shake-and-pick: per trial, the boxes' places and fills are drawn by the world; the
    targets come in random order within each pair of trials (equal counts per material)."""
    from ..models.vibration.classify import VibrationClassifier

    path = shake_model_path()
    clf = VibrationClassifier(path, kind="shake")
    out = ShakeTrials(seed, model=str(path))
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x5EA]))
    targets: list[str] = []
    while len(targets) < trials:
        targets += list(rng.permutation(MATERIALS))
    for i, s in enumerate(range(seed, seed + trials)):
        world, hand, arm = make_box_world(s)
        target = str(targets[i])
        r = shake_and_pick(hand, arm, clf, [(x, 0.0, BOX_GRIP_Z_MM) for x in BOX_X_MM],
                           target, config)
        opened = world.opened
        ok = opened is not None and world.boxes[opened].content == target
        failure = r.failure
        if failure is None and not ok:
            failure = "wrong vote" if opened is not None else "not opened"
        boxes = []
        for k, b in enumerate(world.boxes):             # readings follow BOX_X_MM's order
            rd = r.readings[k] if k < len(r.readings) else None
            boxes.append({"content": b.content, "items": b.items,
                          "vote": rd.vote if rd else None,
                          "predictions": rd.predictions if rd else 0,
                          "shares": {c: round(v, 3) for c, v in rd.shares.items()} if rd
                          else {}})
        out.trials.append({"seed": s, "target": target, "boxes": boxes, "opened": opened,
                           "amplitude_mm": round(50.0 * world.amplitude_gain, 2),
                           "success": failure is None, "failure": failure})
        if progress is not None:
            progress(f"shake seed {s}: {failure or 'ok'}")
    return out


def shake_table(r: ShakeTrials) -> str:
    s = r.summary()
    per = s["per_target"]
    names = {"screws": "Screw-filled box", "rubber_bands": "Rubber-band box"}
    n = s["trials"]
    rate = 100 * s["success"] / n if n else float("nan")
    lines = ["| Metric | " + " | ".join(names[m] for m in MATERIALS) + " |",
             "|---|" + "---|" * len(MATERIALS),
             "| Success rate | " + " | ".join(f"{per[m]['success']}/{per[m]['trials']}"
                                            for m in MATERIALS) + " |",
             "",
             f"overall: {s['success']}/{n} ({rate:.2f} %); box votes correct: "
             f"{s['box_votes_correct']}/{s['box_votes']}"]
    lines += _mode_lines({"": s["failure_modes"]})
    return "\n".join(lines) + "\n"

