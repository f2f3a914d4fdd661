"""Five stacked paper cups in the simulated world: what the nail hears, what a grasp lifts.

The stack stands under the hand at (0, 0). Its rims are the ground truth of a
:class:`~fingertip.sim.physics.CupStackSlide` (rim ``k`` at ``top - k * pitch`` plus the
scene's own jitter), and a downward :meth:`SimArm.slide_z` with the fingers open makes the
nail finger's contact microphone play that scene from the slide's start height at the slide's
speed. The recipe never sees these heights; :meth:`CupWorld.outcome` judges its work.

Rules that decide the outcome (stated, physics-ish):

1. **Grasp**: the height at which the fingers first close (``grasp_z``) picks the cups: the
   cups whose rims lie above it are held (they nest inside the one whose wall is pinched).
   A grasp within ``rim_margin_mm`` (1 mm, half the fingertip's contact patch) of a rim
   pinches the rolled lip: it slips out and nothing is lifted. A grasp above the top rim
   touches nothing (the fingers close on air until the grip times out).
2. **Lift**: the held cups go up with the arm while friction x total grip >= the weight
   carried (``cup_mass_kg`` each, plus the next cup while it clings).
3. **Cling**: the first cup below the held ones clings to them through the nested fit with
   ``cling_n`` (1.5-4 x its weight, per trial), so it comes up too.
4. **Separation**: each stroke in which two opposite fingers move vertically in opposite
   directions (relative move >= ``stroke_mm``, 1 mm) while they grip shears the fit and
   halves the cling; once the cling is below the cup's weight, that cup drops back.
5. **Success** (judged by the experiment): the rims the recipe counted equal the rims the
   nail passed, and the cups lifted at the end (held ones plus any still clinging, lifted
   10 mm or more) equal the requested number.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from ..physics import CupStackSlide, load
from .hand import FINGERS, ObjectSpec, SimArm, SimHand, SimObject, SimWorld

CUP = ObjectSpec("paper cups", stiffness_n_per_mm=0.4, crush_n=3.0, mass_kg=0.004,
                 friction=0.5)
NAIL_FINGER = "f0"
OPPOSITE = (("f0", "f2"), ("f1", "f3"))
NO_CONTACT_MM = 100.0      # beyond any finger's travel


@dataclass(frozen=True)
class CupStack:
    """A trial's stack (ground truth)."""

    top_mm: float
    """Nominal height of the top rim (arm z)."""
    pitch_mm: float
    scene_seed: int
    normal_n: float
    cling_n: float
    n_cups: int = 5
    cup_mass_kg: float = CUP.mass_kg

    def scene(self, z_start_mm: float, slide_mm: float, speed_mm_s: float) -> CupStackSlide:
        return CupStackSlide(speed_mm_s=speed_mm_s, n_cups=self.n_cups, pitch_mm=self.pitch_mm,
                             slide_mm=slide_mm, start_above_mm=z_start_mm - self.top_mm,
                             z_start_mm=z_start_mm, normal_n=self.normal_n, pre_s=0.0,
                             post_s=0.2, seed=self.scene_seed)

    def rims_mm(self) -> np.ndarray:
        """The rims' heights, top first (the scene's jitter included)."""
        return np.asarray(self.scene(self.top_mm, 1.0, 10.0).events()["rim_z_mm"])


@dataclass
class CupWorld(SimWorld):
    stack: CupStack | None = None
    rim_margin_mm: float = 1.0
    stroke_mm: float = 1.0
    grasp_z_mm: float | None = None
    held: int = 0
    """Cups held by the grasp (rims above ``grasp_z_mm``)."""
    on_rim: bool = False
    cling_n: float = 0.0
    clinging: bool = False
    strokes: int = 0
    slides: list[dict] = field(default_factory=list)
    """Each nail slide: start and end height, rims passed (truth)."""
    contact_gaps_mm: dict[str, float] = field(default_factory=dict)

    @property
    def _stack(self) -> CupStack:
        assert self.stack is not None
        return self.stack

    def start_slide(self, dz_mm: float, speed_mm_s: float) -> None:
        z0 = self.arm_z_mm
        super().start_slide(dz_mm, speed_mm_s)
        at_stack = max(abs(v) for v in self.arm_xy_mm) < 5.0
        fingers_open = all(p == 0.0 for p in self.positions.values())
        if dz_mm < 0 and at_stack and fingers_open and self.grasp_z_mm is None:
            scene = self._stack.scene(z0, -dz_mm, speed_mm_s)
            self.audio.add(scene, self.t_s, scene.duration_s, (NAIL_FINGER,))
            rims = self._stack.rims_mm()
            self.slides.append({"z_start_mm": z0, "z_end_mm": z0 + dz_mm,
                                "rims_passed": int(np.sum((rims < z0) & (rims > z0 + dz_mm)))})

    def _engage(self) -> None:
        """The fingers start closing: which cups are between them is decided here."""
        st = self._stack
        z = self.arm_z_mm
        rims = st.rims_mm()
        self.grasp_z_mm = z
        self.held = int(np.sum(rims > z))
        self.on_rim = bool(np.any(np.abs(rims - z) < self.rim_margin_mm))
        gaps = self.contact_gaps_mm if self.held else dict.fromkeys(FINGERS, NO_CONTACT_MM)
        self.obj.gaps_mm = dict(gaps)
        self.clinging = 0 < self.held < st.n_cups
        self.cling_n = st.cling_n

    def holds(self) -> bool:
        st = self._stack
        if self.on_rim or not self.held or self.obj.broken:
            return False
        carried = (self.held + (1 if self.clinging else 0)) * st.cup_mass_kg * 9.81
        return self.obj.spec.friction * sum(self.contact_forces().values()) >= carried

    def advance(self, dt: float) -> None:
        if self.grasp_z_mm is None and any(p > 0 for p in self.positions.values()):
            self._engage()
        super().advance(dt)

    def step_fingers_z(self, increments_mm: Mapping[str, float]) -> None:
        super().step_fingers_z(increments_mm)
        forces = self.contact_forces()
        for a, b in OPPOSITE:
            da, db = increments_mm.get(a, 0.0), increments_mm.get(b, 0.0)
            gripping = forces[a] > 0 and forces[b] > 0 and self.obj.lifted_mm > 0
            if gripping and da * db < 0 and abs(da - db) >= self.stroke_mm:
                self.strokes += 1
                self.cling_n *= 0.5
                if self.clinging and self.cling_n < self._stack.cup_mass_kg * 9.81:
                    self.clinging = False

    def lifted_cups(self, min_mm: float = 10.0) -> int:
        if self.obj.lifted_mm < min_mm:
            return 0
        return self.held + (1 if self.clinging else 0)


def make_cup_world(seed: int, *, hand_seed: int = 100
                   ) -> tuple[CupWorld, SimHand, SimArm]:
    """One cup trial: seeded rim pitch (7 +- 0.5 mm), stack height (top rim at 100-140 mm),
    normal force of the nail on the wall (0.3-0.6 N: the rims' clicks against the wall's
    scrape), cling of the nested fit, microphone gain (x0.6-1.5) and mains (50/60 Hz), and
    where each finger meets the cup (0.3-1.3 mm of travel)."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0xC0B5]))
    stack = CupStack(top_mm=float(rng.uniform(100.0, 140.0)),
                     pitch_mm=float(rng.uniform(6.5, 7.5)),
                     scene_seed=int(rng.integers(1 << 30)),
                     normal_n=float(rng.uniform(0.3, 0.6)),
                     cling_n=float(rng.uniform(1.5, 4.0)) * CUP.mass_kg * 9.81)
    gaps = {f: float(rng.uniform(0.3, 1.3)) for f in FINGERS}
    chain = {"preamp_gain": load().preamp.gain * float(rng.uniform(0.6, 1.5)),
             "mains_hz": float(rng.choice([50.0, 60.0]))}
    world = CupWorld(SimObject(CUP, dict.fromkeys(FINGERS, NO_CONTACT_MM)), rng,
                     angles_deg={f: float(rng.uniform(-20, 20)) for f in FINGERS},
                     heights_mm={f: float(rng.uniform(1.0, 4.0)) for f in FINGERS},
                     audio_seed=seed, chain_options=chain, stack=stack, contact_gaps_mm=gaps)
    hand = SimHand(world, {f: hand_seed + i for i, f in enumerate(FINGERS)})
    return world, hand, SimArm(world)


def approach_height(world: CupWorld) -> float:
    """Where the operator (or the wrist camera, which sees the top rim) puts the nail to
    start: 2.5-4 mm above the top rim. The recipe gets this number, not the rims."""
    rng = np.random.default_rng(np.random.SeedSequence([world.audio_seed, 0xA9]))
    return world._stack.top_mm + float(rng.uniform(2.5, 4.0))
