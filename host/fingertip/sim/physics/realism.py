"""The imperfections of a virtual fingertip's strain path: one set of switches
(:class:`Realism`) and the sizes of the documented error sources (``realism.toml``).

The strain model (:mod:`.strain`) has its own imperfections, sized in the hardware's
``fingertip.toml``: hysteresis, a short first-order creep, the unit's response to temperature
(apparent strain, span, gauge factor, leads), the bridge's and the HX711's offsets and the
moment shunted past the prism by the base. On top of them come the error sources that a real
calibration session also meets, with sizes from datasheets or published measurements
(docs/simulation.md, "Error budget"):

- ``hx711_noise``: the datasheet's input noise;
- ``hx711_drift``: the HX711's offset and gain temperature coefficients;
- ``thermal``: the room's temperature over a session (HVAC cycle and daily drift) acting on
  the gauges' thermal output, gauge-factor and span coefficients, and on the bridge
  completion resistors' TCR;
- ``creep``: slow creep of the PLA prism and the glue line (Prony series);
- ``skin``: the silicone skin's stress relaxation under a held indentation and the vertical
  friction force its shear carries when the cap tilts (used by the calibration sweep);
- ``contact``: spread of the real contact height and direction, and the bending moment of a
  vertical force at the side of the fingertip;
- ``unit_spread``: glue and placement spread between units (fingertip.toml [variation]);
- ``mount``: relaxation of the TPU base that carries part of the moment past the gauges.

``Realism()`` has everything on (the default of every virtual unit); ``Realism.ideal()`` is the
earlier, ideal simulator (the model's own imperfections, unit spread and white noise);
``Realism.none()`` has none of the error sources; ``Realism.bare()`` has nothing at all (the
closed-form beam and bridge); ``Realism().without("creep")`` drops one, for an ablation.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, fields
from functools import lru_cache
from importlib import resources
from typing import Any, ClassVar

import numpy as np

from ...hardware.tables import read_tables, tomllib
from .scan import affine_scan

REALISM_FILE = "realism.toml"
SCHEMA = 1


@dataclass(frozen=True)
class Realism:
    """Which imperfections a virtual unit has (all by default): the documented error
    sources (:meth:`sources`) and the strain model's own (:meth:`model_effects`)."""

    hx711_noise: bool = True
    hx711_drift: bool = True
    thermal: bool = True
    creep: bool = True
    skin: bool = True
    contact: bool = True
    unit_spread: bool = True
    mount: bool = True
    hysteresis: bool = True
    """Prandtl-Ishlinskii hysteresis of the prism and glue (fingertip.toml [hysteresis])."""
    short_creep: bool = True
    """First-order creep and recovery, seconds (fingertip.toml [creep])."""
    thermal_response: bool = True
    """The unit's response to its temperature: apparent strain, span, gauge factor, leads and
    the HX711's drift. Off, no temperature acts at all, whatever ``temperature_c`` says."""
    offsets: bool = True
    """Bridge imbalance, lead resistance, glue pre-strain and HX711 offset."""
    shunt: bool = True
    """Moment shared by the TPU base and the skin (angle- and load-dependent)."""

    MODEL_EFFECTS: ClassVar[tuple[str, ...]] = (
        "hysteresis", "short_creep", "thermal_response", "offsets", "shunt")

    @classmethod
    def sources(cls) -> tuple[str, ...]:
        """The documented error sources (the ablations' list)."""
        return tuple(f.name for f in fields(cls) if f.name not in cls.MODEL_EFFECTS)

    @classmethod
    def model_effects(cls) -> tuple[str, ...]:
        return cls.MODEL_EFFECTS

    @classmethod
    def none(cls) -> Realism:
        """None of the error sources: the nominal unit, noiseless, at the reference
        temperature (the model's own imperfections stay)."""
        return cls(**{name: False for name in cls.sources()})

    @classmethod
    def bare(cls) -> Realism:
        """Nothing at all: the closed-form beam, the exact bridge and the HX711's scale."""
        return cls(**{f.name: False for f in fields(cls)})

    @classmethod
    def ideal(cls) -> Realism:
        """The "ideal sensor" of the project's earlier figures: each unit's own spread and the
        HX711's white noise, no other error source (the simulator before the error budget)."""
        return cls.none().only("hx711_noise", "unit_spread")

    def without(self, *names: str) -> Realism:
        return dataclasses.replace(self, **{_checked(n): False for n in names})

    def only(self, *names: str) -> Realism:
        """Only the named error sources (for "what does this one add" runs); the model's own
        imperfections as in ``self``."""
        keep = {n: getattr(self, n) for n in self.MODEL_EFFECTS}
        return dataclasses.replace(Realism.none(), **keep, **{_checked(n): True for n in names})

    @property
    def active(self) -> tuple[str, ...]:
        """The error sources that are on."""
        return tuple(n for n in self.sources() if getattr(self, n))


def _checked(name: str) -> str:
    names = tuple(f.name for f in fields(Realism))
    if name not in names:
        raise ValueError(f"unknown error source or imperfection {name!r}; one of "
                         f"{', '.join(names)}")
    return name


# --- parameters ---------------------------------------------------------------------------

@dataclass(frozen=True)
class HX711Drift:
    offset_nv_per_k: float
    gain_ppm_per_k: float


@dataclass(frozen=True)
class Thermal:
    hvac_amplitude_k: float
    hvac_period_s: tuple[float, ...]
    drift_amplitude_k: float
    drift_period_s: float
    completion_tcr_ppm_per_k: float


@dataclass(frozen=True)
class Creep:
    fraction: tuple[float, ...]
    tau_s: tuple[float, ...]
    unit_rel: float


@dataclass(frozen=True)
class Skin:
    modulus_mpa: float
    thickness_mm: float
    relax_fraction: tuple[float, ...]
    relax_tau_s: tuple[float, ...]
    friction: float
    indenter_diameter_mm: float

    @property
    def shear_stiffness_n_per_m(self) -> float:
        """Shear stiffness of the skin under the indenter's patch: G A / t, G = E / 3."""
        area = math.pi * (self.indenter_diameter_mm * 1e-3) ** 2 / 4
        return self.modulus_mpa * 1e6 / 3 * area / (self.thickness_mm * 1e-3)

    def relaxation(self, t_s: np.ndarray | float) -> np.ndarray:
        """Relaxation modulus over its initial value, G(t) / G(0)."""
        t = np.asarray(t_s, float)
        g = np.asarray(self.relax_fraction)
        tau = np.asarray(self.relax_tau_s)
        return (1 - g.sum() + (g * np.exp(-t[..., None] / tau)).sum(-1))


@dataclass(frozen=True)
class Contact:
    height_sd_mm: float
    angle_sd_deg: float
    surface_radius_mm: float


@dataclass(frozen=True)
class Mount:
    relax_fraction: tuple[float, ...]
    relax_tau_s: tuple[float, ...]


_SECTIONS: dict[str, type] = {"hx711_drift": HX711Drift, "thermal": Thermal, "creep": Creep,
                              "skin": Skin, "contact": Contact, "mount": Mount}


@dataclass(frozen=True)
class RealismParams:
    hx711_drift: HX711Drift
    thermal: Thermal
    creep: Creep
    skin: Skin
    contact: Contact
    mount: Mount


def from_dict(data: dict[str, Any], where: str = REALISM_FILE) -> RealismParams:
    out = read_tables(data, _SECTIONS, where, SCHEMA)
    p = RealismParams(**out)
    for name in ("creep", "skin", "mount"):
        sec = getattr(p, name)
        frac = sec.fraction if name == "creep" else sec.relax_fraction
        tau = sec.tau_s if name == "creep" else sec.relax_tau_s
        if len(frac) != len(tau) or min(tau, default=1.0) <= 0:
            raise ValueError(f"{where} [{name}]: fractions and times differ in length or a "
                             f"time is not positive")
    if sum(p.skin.relax_fraction) >= 1 or sum(p.mount.relax_fraction) >= 1:
        raise ValueError(f"{where}: relaxation fractions must add up to less than 1")
    return p


@lru_cache(maxsize=1)
def load() -> RealismParams:
    text = resources.files(__package__).joinpath(REALISM_FILE).read_text(encoding="utf-8")
    return from_dict(tomllib.loads(text))


# --- one unit's draw ----------------------------------------------------------------------

@dataclass(frozen=True)
class UnitRealism:
    """What one unit draws for the sources (arrays: one value per channel)."""

    offset_drift_v_per_k: np.ndarray
    gain_drift_per_k: np.ndarray
    completion_tcr_per_k: np.ndarray
    """(4, 3): R_2, R_3, R_4 of each bridge."""
    hvac_period_s: float
    hvac_phase: float
    drift_phase: float
    creep_fraction: np.ndarray
    """(4, K) Prony fractions of the slow creep (PLA, glue, TPU base) on the gauge strain."""
    creep_tau_s: np.ndarray
    """(K,)"""

    @classmethod
    def draw(cls, p: RealismParams, realism: Realism, shunt: float,
             rng: np.random.Generator) -> UnitRealism:
        """Draw every quantity (so the draw does not depend on the flags), then zero the
        ones whose source is off. ``shunt``: the unit's mean moment fraction in the base."""
        d, th, cr, mo = p.hx711_drift, p.thermal, p.creep, p.mount
        off = rng.normal(0, d.offset_nv_per_k * 1e-9, 4)
        gain = rng.normal(0, d.gain_ppm_per_k * 1e-6, 4)
        # Within the datasheet's limit, uniformly (the limit is no standard deviation).
        tcr = rng.uniform(-1, 1, (4, 3)) * th.completion_tcr_ppm_per_k * 1e-6
        lo, hi = th.hvac_period_s
        period = float(np.exp(rng.uniform(np.log(lo), np.log(hi))))
        ph1, ph2 = rng.uniform(0, 2 * math.pi, 2)
        k_pla = np.asarray(cr.fraction)[None, :] * np.exp(
            rng.normal(0, cr.unit_rel, (4, len(cr.fraction))) - cr.unit_rel ** 2 / 2)
        # The base relaxes: the moment it carried (fraction `shunt`) moves to the prism.
        k_mount = shunt * np.asarray(mo.relax_fraction)[None, :].repeat(4, 0)
        if not realism.hx711_drift:
            off, gain = off * 0, gain * 0
        if not realism.thermal:
            tcr = tcr * 0
        if not realism.creep:
            k_pla = k_pla * 0
        if not realism.mount:
            k_mount = k_mount * 0
        return cls(off, gain, tcr, period, float(ph1), float(ph2),
                   np.concatenate([k_pla, k_mount], axis=1),
                   np.asarray(cr.tau_s + mo.relax_tau_s, float))


def lab_temperature(p: RealismParams, unit: UnitRealism, reference_c: float):
    """The room's temperature over a session: T(t) for t in seconds (array in, array out).

    An HVAC cycle (its amplitude and a period drawn per unit) on a slow daily drift; both
    start at a random phase, so the tare at t = 0 is at some point of the cycle."""
    th = p.thermal

    def temperature(t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, float)
        return (reference_c
                + th.hvac_amplitude_k * np.sin(2 * math.pi * t / unit.hvac_period_s
                                               + unit.hvac_phase)
                + th.drift_amplitude_k * np.sin(2 * math.pi * t / th.drift_period_s
                                                + unit.drift_phase))

    return temperature


class SlowCreep:
    """Prony creep on the gauge strain: y = x + sum_k f_k s_k, ds_k/dt = (x - s_k) / tau_k.

    A step x = 1 at t = 0 reads 1 + sum f_k (1 - exp(-t / tau_k)). State carries across
    calls (one continuous history); exact for inputs held between samples."""

    def __init__(self, fraction: np.ndarray, tau_s: np.ndarray) -> None:
        self.fraction = np.asarray(fraction, float)       # (4, K)
        self.tau_s = np.asarray(tau_s, float)             # (K,)
        self.reset()

    @property
    def active(self) -> bool:
        return bool(np.any(self.fraction != 0))

    def reset(self) -> None:
        self.state = np.zeros(self.fraction.shape)
        self.t_last: float | None = None

    def apply(self, x: np.ndarray, t: np.ndarray, update: bool = True) -> np.ndarray:
        if not self.active or x.shape[0] == 0:
            return x
        dt = np.diff(t, prepend=t[0] if self.t_last is None else self.t_last)
        if np.any(dt < 0):
            raise ValueError("times must not go backwards")
        if x.shape[0] == 1:      # one conversion (the device path): no scan needed
            a1 = np.exp(-dt[0] / self.tau_s)                          # (K,)
            st = a1 * self.state + (1 - a1) * x[0][:, None]
            out = x + (self.fraction * st).sum(axis=1)[None, :]
            last = st
        else:
            a = np.broadcast_to(np.exp(-dt[:, None] / self.tau_s)[:, None, :],
                                (x.shape[0], *self.fraction.shape))  # (N, 4, K)
            st = affine_scan(a, (1 - a) * x[:, :, None], self.state)
            out = x + (self.fraction * st).sum(axis=2)
            last = st[-1]
        if update:
            self.state = last.copy()
            self.t_last = float(t[-1])
        return out


def eccentric_strain(f: np.ndarray, fz: np.ndarray, point: np.ndarray, radius_m: float,
                     ei: float) -> np.ndarray:
    """Strain (N, 4) from the moment of a vertical force at the side of the fingertip.

    The contact lies on the side the lateral force comes from (at -r F/|F|); a compressive
    (downward, positive) ``fz`` there gives the moment r fz about the same axis as the
    lateral force's, opposing it: eps = +(P . F/|F|) r fz / (E I) for gauge points P (N, 4, 2)
    or (4, 2)."""
    mag = np.hypot(f[:, 0], f[:, 1])
    unit = np.divide(f, mag[:, None], out=np.zeros_like(f), where=mag[:, None] > 0)
    proj = np.einsum("...ij,...j->...i", point, unit[:, None, :]) if point.ndim == 3 \
        else unit @ point.T
    return proj * (radius_m * np.asarray(fz, float))[:, None] / ei
