"""The fingertip as a MuJoCo sensor: contacts in, HX711 counts and piezo blocks out.

Call :meth:`FingertipSensor.step` after every ``mj_step``. Fidelity levels ("model only what
a scene needs"):

- ``wrench``: the mean contact force on the fingertip (its frame, newtons) and where it acts
  (millimetres below the nail tip), once per HX711 conversion;
- ``strain``: the same force through the virtual fingertip's strain model
  (:class:`VirtualStrainSensor`: location-dependent gauge response, unit spread, hysteresis,
  creep, temperature, noise, each error source switchable with ``realism``) to four counts;
- ``full``: counts and the piezo's 44.1 kHz blocks (:class:`~.piezo.PiezoStream`).

Each conversion reads the force averaged over its period (an HX711 integrates its input over
the conversion), at the chip's own clock (``rate_sps``), so the counts do not depend on the
physics step. The strain model runs on ``batch`` conversions at once (its cost is mostly per
call): counts appear up to ``batch / rate_sps`` seconds of simulated time after the
conversion; :meth:`flush` converts what is pending.

The skin (``realism.skin``): silicone relaxes under a held load; MuJoCo's contact does not, so
its Prony relaxation (``realism.toml`` [skin]) filters the force between the contact and the
cap (quasi-linear viscoelasticity: a step of force reads F (1 - sum g_i (1 - exp(-t/tau_i)))).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from ._require import mujoco
from .attach import AttachedFingertip
from .contacts import ContactReader, Touch
from .piezo import Block, PiezoStream
from .project import (
    FingertipParams,
    Material,
    Realism,
    VirtualStrainSensor,
    load_params,
    load_realism,
    material_named,
)

FIDELITIES = ("wrench", "strain", "full")
NAIL_IMPACT_S, SKIN_IMPACT_S = 3e-4, 3e-3
NAIL_RELEASE_S, SKIN_RELEASE_S = 5e-4, 2e-3
IMPACT_N_PER_MM_S = 0.004
"""Make transient per approach speed (the virtual fingertip's scenes: 0.12 N at 30 mm/s)."""
RELEASE_FRACTION = 0.35
DEBOUNCE_S = 0.02
"""A contact gap shorter than this is MuJoCo's flicker of a sliding contact, not a release
(by default the piezo renders this much behind the physics, so a release lands where it
began)."""
REFLEX_AUDIO = {"audio_block": 512, "audio_lag_s": 0.0}
"""Audio options for a loop that reacts to the piezo (a slip reflex): blocks as soon as a
sound card at its driver's low latency would deliver them (512 samples, 11.6 ms), a release's
click up to ``DEBOUNCE_S`` late in exchange. The defaults (4096 samples, rendered
``DEBOUNCE_S`` behind) cost less per step and place every release exactly, but deliver the
sound up to 113 ms after it happened, later than any real capture."""
NORMAL_TAU_S = 0.01
"""Averaging time of the normal force the sliding texture feels (longer than MuJoCo's
flicker of a sliding contact, a step or two; shorter than any stroke of a recipe)."""
_ZERO3 = np.zeros(3)
_ZERO3.flags.writeable = False


@dataclass
class Reading:
    """One HX711 conversion of one fingertip."""

    t: float
    """Simulation time of the conversion (s)."""
    force_n: np.ndarray
    """MuJoCo's mean contact force on the fingertip over the conversion, its frame (x: the
    nail's side): the truth."""
    height_mm: float
    """Where the force acts: millimetres below the nail tip (0 without contact)."""
    cap_force_n: np.ndarray | None = None
    """The force that reaches the cap through the skin (relaxed when ``realism.skin``): what
    the strain model bends the prism with."""
    counts: np.ndarray | None = None
    """(4,) int64 HX711 counts (``strain``, ``full``)."""
    raw: np.ndarray | None = None
    """(4,) the same before rounding and saturation (what the virtual firmware takes)."""


class FingertipSensor:
    """One attached fingertip on a compiled model: ``sensor.step()`` after each ``mj_step``.

    ``materials`` maps geom names of the scene to material names (``physics.materials``) or
    :class:`Material` objects, the surfaces the nail slides over; other geoms sound like
    ``default_material``. ``audio_block`` (samples) and ``audio_lag_s`` (how far behind the
    physics the piezo renders) set how late the sound arrives: see ``REFLEX_AUDIO``.
    """

    def __init__(self, model, data, tip: AttachedFingertip, *, fidelity: str = "strain",
                 seed: int | None = 0, realism: Realism | None = None,
                 rate_sps: int = 80, batch: int = 8,
                 materials: dict[str, str | Material] | None = None,
                 default_material: str = "tpu",
                 audio_block: int = 4096, audio_lag_s: float = DEBOUNCE_S,
                 params: FingertipParams | None = None) -> None:
        if fidelity not in FIDELITIES:
            raise ValueError(f"fidelity must be one of {', '.join(FIDELITIES)}, not "
                             f"{fidelity!r}")
        if batch < 1:
            raise ValueError(f"batch must be at least 1 conversion, not {batch}")
        if not 0.0 <= audio_lag_s < 1.0:
            raise ValueError(f"audio_lag_s must be in [0, 1) s, not {audio_lag_s}")
        self.audio_lag_s = float(audio_lag_s)
        mj = mujoco()
        self.params = params or load_params()
        self.m, self.d, self.tip, self.fidelity = model, data, tip, fidelity
        self.reader = ContactReader(model, data, tip)
        self.realism = Realism() if realism is None else realism
        self.rate_sps, self.batch = rate_sps, batch
        self.period = 1.0 / rate_sps
        self.strain = None
        if fidelity != "wrench":
            self.strain = VirtualStrainSensor(seed, params=self.params,
                                              rate_sps=rate_sps, realism=self.realism)
        self.piezo = None
        if fidelity == "full":
            noisy = self.realism.hx711_noise
            self.piezo = PiezoStream(self.params, seed, block=audio_block, hum=noisy,
                                     noise=noisy, default_material=default_material)
        self._mat: list[Material | None] = [None] * model.ngeom
        default = material_named(default_material)
        for g in range(model.ngeom):
            self._mat[g] = default
        for geom, name in (materials or {}).items():
            gid = mj.mj_name2id(model, mj.mjtObj.mjOBJ_GEOM, geom)
            if gid < 0:
                raise ValueError(f"no geom {geom!r} in the model for material {name!r}")
            self._mat[gid] = name if isinstance(name, Material) else material_named(name)
        skin = load_realism().skin
        self._skin_g = np.asarray(skin.relax_fraction) if self.realism.skin else np.zeros(0)
        self._skin_tau = np.asarray(skin.relax_tau_s)
        self._skin_state = np.zeros((len(self._skin_g), 1, 3))
        self._skin_last = np.zeros(3)
        self.reset_clock()

    def reset_clock(self) -> None:
        """Start converting at the data's current time (after a reset or a keyframe)."""
        self._next_conv = self.d.time + self.period
        self._acc_f = np.zeros(3)
        self._acc_p = np.zeros(3)
        self._steps = 0
        self._touching_steps = 0
        self._pending: list[tuple[float, np.ndarray, float]] = []
        self._ready: list[Reading] = []
        self._contact = False
        self._gap_since: float | None = None
        self._held = Touch()
        self.touch = Touch()
        """This step's deepest contact (``full`` only): what other sounds reach the nail
        through (:mod:`.box_sound`)."""
        self._normal = 0.0
        self._last_make = (0.0, True)

    # --- per physics step ------------------------------------------------------------------

    def step(self) -> None:
        """Read this step's contacts; convert when the HX711's period is over."""
        r = self.reader
        touching = r.net_found[0] > 0
        self._steps += 1
        if touching:
            self._acc_f += r.net_force
            self._acc_p += r.net_pos
            self._touching_steps += 1
        if self.piezo is not None:
            self._sound(touching)
        if self.d.time >= self._next_conv - 1e-12:
            self._convert()

    def _sound(self, touching: bool) -> None:
        t = self.d.time
        touch = self.touch = self.reader.touch() if touching else Touch()
        if touch.found and touch.normal_n > 0:
            if not self._contact:  # a make after a real separation
                amp = IMPACT_N_PER_MM_S * touch.approach_mm_s * (1.0 if touch.nail else 0.4)
                back = touch.depth_m / max(touch.approach_mm_s * 1e-3, 1e-6)
                self.piezo.impact(max(t - back, t - self.m.opt.timestep), amp,
                                  NAIL_IMPACT_S if touch.nail else SKIN_IMPACT_S)
                self._last_make = (amp, touch.nail)
                self._contact = True
            self._gap_since = None
            self._held = touch
        elif self._contact:
            # A sliding contact flickers in MuJoCo (micrometre separations for a few steps):
            # hold the last contact through gaps shorter than DEBOUNCE_S; a longer one is a
            # release, placed where the gap began.
            if self._gap_since is None:
                self._gap_since = t
            if t - self._gap_since < DEBOUNCE_S:
                touch = self._held
            else:
                amp, nail = self._last_make
                self.piezo.impact(self._gap_since, -RELEASE_FRACTION * amp,
                                  NAIL_RELEASE_S if nail else SKIN_RELEASE_S)
                self._contact = False
        # The normal force the texture feels: its average over NORMAL_TAU_S, flicker gaps
        # counted as the zeros they are. A sliding contact that MuJoCo separates for one step
        # in three carries the load in the other two, half again the real load: held through
        # the gaps, that peak made a slide sound as if pressed up to 1.4 times harder.
        raw = touch.normal_n if touch.found and self._gap_since is None else 0.0
        a = min(1.0, self.m.opt.timestep / NORMAL_TAU_S)
        self._normal = self._normal + a * (raw - self._normal) if self._contact else 0.0
        mat = self._mat[touch.other_geom] if touch.found else None
        self.piezo.push(t, touch.slip_mm_s, self._normal if touch.found else 0.0, mat,
                        touch.nail)
        self.piezo.render(t - self.audio_lag_s)

    def _convert(self) -> None:
        r = self.reader
        if self._touching_steps:
            force = -(self._acc_f @ r.rot) / self._steps
            z = r.point_in_tip(self._acc_p / self._touching_steps)[2]
            height = self.tip.geometry.height_below_nail_mm(float(z))
            self._acc_f = np.zeros(3)
            self._acc_p = np.zeros(3)
        else:
            force, height = _ZERO3, 0.0
        self._pending.append((self._next_conv, force, height))
        self._steps = self._touching_steps = 0
        self._next_conv += self.period
        if len(self._pending) >= self.batch:
            self.flush()

    def flush(self) -> None:
        """Run the strain model on the pending conversions now."""
        if not self._pending:
            return
        t = np.array([p[0] for p in self._pending])
        f = np.array([p[1] for p in self._pending])
        h = np.array([p[2] for p in self._pending])
        self._pending = []
        cap = self._relax(t, f)
        if self.strain is None:
            self._ready.extend(Reading(ti, fi, hi, ci) for ti, fi, hi, ci
                               in zip(t, f, h, cap, strict=True))
            return
        # The strain model's axial force is compressive-positive: the cap pushed down (-z).
        raw = self.strain.raw_counts_batch(cap[:, :2], h, t, -cap[:, 2])
        hx = self.params.hx711
        counts = np.clip(np.rint(raw), hx.count_min, hx.count_max).astype(np.int64)
        self._ready.extend(Reading(ti, fi, hi, ci, ni, ri) for ti, fi, hi, ci, ni, ri
                           in zip(t, f, h, cap, counts, raw, strict=True))

    def _relax(self, t: np.ndarray, f: np.ndarray) -> np.ndarray:
        if not len(self._skin_g):
            return f
        dt = np.diff(t, prepend=t[0] - self.period)
        df = np.diff(f, axis=0, prepend=self._skin_last[None, :])
        self._skin_last = f[-1].copy()
        out = f * (1 - self._skin_g.sum())
        for i, (g, tau) in enumerate(zip(self._skin_g, self._skin_tau, strict=True)):
            a = float(np.exp(-dt[0] / tau))  # the conversions are evenly spaced
            h, self._skin_state[i] = lfilter([1.0], [1.0, -a], df, axis=0,
                                             zi=self._skin_state[i])
            out += g * h
        return out

    # --- results ---------------------------------------------------------------------------

    def readings(self) -> list[Reading]:
        """Conversions finished since the last call, in time order."""
        out, self._ready = self._ready, []
        return out

    def audio(self) -> list[Block]:
        """Piezo blocks rendered since the last call (``full`` only)."""
        if self.piezo is None:
            raise RuntimeError(f"fidelity {self.fidelity!r} has no audio: use 'full'")
        return self.piezo.read()

    def wrench(self) -> tuple[np.ndarray, float]:
        """The contact force on the fingertip now (its frame, N) and its height below the
        nail tip (mm), without waiting for a conversion."""
        r = self.reader
        if not r.touching:
            return np.zeros(3), 0.0
        z = r.point_in_tip(r.net_pos)[2]
        return r.to_tip(r.force_on_tip()), self.tip.geometry.height_below_nail_mm(float(z))
