"""Strain-gauge channel physics: a force on the cap -> prism bending -> bridge -> HX711 counts.

Chain for each of the four faces (face i has outward normal at i * 90 degrees: +x, +y, -x, -y):

1. Euler-Bernoulli cantilever. A force F = (Fx, Fy) on the rigid cap at height z_c bends the
   prism; at the gauge (height z_g) the moment is |F| (z_c - z_g) and the axial surface strain
   at section point P is  eps_zz = -(F . P) (z_c - z_g) / (E I)  (the face the force pushes
   towards is compressed), with P = c n_i + e t_i (gauge centre, c = half side, e = the
   gauge's lateral offset). An axial force Fz (compressive positive) adds -Fz / (E A).
   A fraction kappa of the moment bypasses the prism through the TPU base and the skin.
2. The gauge reads the strain along its grid axis, rotated by a small misalignment theta,
   with transverse strain -nu eps_zz, the in-plane shear (F . t_i)(c^2 - e^2) / (2 I G),
   its transverse sensitivity and the glue's strain transfer.
3. Hysteresis (Prandtl-Ishlinskii: a weighted sum of play operators) and creep (first-order
   relaxation) act on that mechanical strain; temperature adds an apparent strain and a span
   change.
4. Quarter bridge, exact:  V = V_ex (R_g / (R_g + R_2) - R_3 / (R_3 + R_4)),  with
   R_g = R_g0 (1 + GF eps) + R_lead; HX711 offset and input noise; counts = V * 2^23 /
   (0.5 AVDD / gain); rounding and saturation at the 24-bit limits.

Every unit draws its own deviations (gauge angle, position, gauge factor, glue, modulus,
resistor tolerances, pre-strain, base shunt, hysteresis, creep, thermal coefficients, noise)
from its seed, so each virtual fingertip needs its own calibration. On top of this, every unit
has the documented error sources of :mod:`.realism` (the room's temperature, slow creep, the
bridge resistors' and the HX711's drift, the eccentric moment of a vertical contact force,
the base's relaxation). Every imperfection, the model's own and the error sources, is one
switch of :class:`~.realism.Realism` (``realism=``).
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from . import realism as _realism
from ...hardware import FingertipParams, load, section_rigidity
from .realism import Realism, SlowCreep, UnitRealism, eccentric_strain, lab_temperature
from .scan import affine_scan, play_scan
from .source import LOOKAHEAD, LookaheadSource

FACE_ANGLES = np.array([0.0, 0.5, 1.0, 1.5]) * math.pi
"""Outward normal of each face (channel i), radians from +x."""
NORMALS = np.stack([np.cos(FACE_ANGLES), np.sin(FACE_ANGLES)], axis=1).round(15)
TANGENTS = np.stack([-np.sin(FACE_ANGLES), np.cos(FACE_ANGLES)], axis=1).round(15)

Temperature = float | Callable[[np.ndarray], np.ndarray]
CHUNK = 1 << 15
"""Samples per scan chunk in the batch path (state carries across chunks: same result)."""


@dataclass(frozen=True)
class UnitVariation:
    """One unit's deviations from the nominal design (arrays: one value per channel)."""

    gauge_angle_rad: np.ndarray
    gauge_dz_m: np.ndarray
    gauge_lateral_m: np.ndarray
    gauge_factor: np.ndarray
    glue_transfer: np.ndarray
    modulus_pa: float
    prism_side_m: float
    gauge_ohm: np.ndarray
    completion_ohm: np.ndarray
    """(4, 3): R_2 (gauge's half), R_3, R_4 (reference half)."""
    prestrain: np.ndarray
    hx711_offset_v: np.ndarray
    shunt: float
    shunt_phase_rad: float
    hysteresis_gain: np.ndarray
    creep_fraction: np.ndarray
    creep_tau_s: np.ndarray
    apparent_strain_per_k: np.ndarray
    span_tc_per_k: np.ndarray
    noise_scale: np.ndarray

    @classmethod
    def nominal(cls, p: FingertipParams) -> UnitVariation:
        return cls.draw(p, None)

    @classmethod
    def draw(cls, p: FingertipParams, rng: np.random.Generator | None) -> UnitVariation:
        """Draw a unit (``rng`` None: the nominal unit, every deviation zero)."""
        v, g = p.variation, p.gauge

        def n(sigma: float, size: int | tuple[int, ...] = 4) -> np.ndarray:
            if rng is None:
                return np.zeros(size)
            return rng.normal(0.0, sigma, size)

        def pos(mean: float, rel: float, size: int = 4) -> np.ndarray:
            """A positive quantity with relative scatter (log-normal)."""
            if rng is None:
                return np.full(size, mean)
            return mean * np.exp(rng.normal(0.0, rel, size) - rel ** 2 / 2)

        apparent = (p.materials.pla_cte_per_k - g.self_compensation_cte_per_k)
        return cls(
            gauge_angle_rad=np.radians(n(v.gauge_angle_deg)),
            gauge_dz_m=n(v.gauge_z_mm) * 1e-3,
            gauge_lateral_m=n(v.gauge_lateral_mm) * 1e-3,
            gauge_factor=g.gauge_factor * (1 + n(v.gauge_factor_rel)),
            glue_transfer=np.clip(g.glue_transfer + n(v.glue_transfer), 0.5, 1.0),
            modulus_pa=float(pos(p.modulus_pa, v.modulus_rel, 1)[0]),
            prism_side_m=(p.geometry.prism_side_mm + float(n(v.prism_side_mm, 1)[0])) * 1e-3,
            gauge_ohm=g.resistance_ohm * (1 + n(v.gauge_resistance_rel)),
            completion_ohm=p.bridge.completion_ohm * (1 + n(v.completion_rel, (4, 3))),
            prestrain=(v.glue_prestrain_mean_ue + n(v.glue_prestrain_ue)) * 1e-6
            if rng is not None else np.zeros(4),
            hx711_offset_v=n(v.hx711_offset_uv) * 1e-6,
            shunt=float(max(0.0, p.base.moment_shunt + float(n(v.moment_shunt, 1)[0]))),
            shunt_phase_rad=0.0 if rng is None else float(rng.uniform(0, 2 * math.pi)),
            hysteresis_gain=pos(p.hysteresis.gain, v.hysteresis_rel),
            creep_fraction=pos(p.creep.fraction, v.creep_rel),
            creep_tau_s=pos(p.creep.tau_s, v.creep_tau_rel),
            apparent_strain_per_k=apparent + n(v.apparent_strain_ue_per_k) * 1e-6,
            span_tc_per_k=p.thermal.span_tc_per_k + n(v.span_tc_per_k),
            noise_scale=pos(1.0, v.noise_rel),
        )


@dataclass
class _State:
    play: np.ndarray            # (4, K) play-operator outputs
    creep: np.ndarray           # (4,) creep filter state
    t_last: float | None = None

    def copy(self) -> _State:
        return _State(self.play.copy(), self.creep.copy(), self.t_last)


@dataclass(frozen=True)
class SensorState:
    """What :meth:`VirtualStrainSensor.save_state` keeps."""
    strain: _State
    slow: np.ndarray
    slow_t_last: float | None
    noise: dict


@dataclass
class _Batch:
    """Intermediate results of one batch (for inspection and tests)."""

    surface: np.ndarray
    gauge: np.ndarray
    mechanical: np.ndarray
    total: np.ndarray
    volts: np.ndarray
    counts_f: np.ndarray
    extra: dict = field(default_factory=dict)


class VirtualStrainSensor:
    """One virtual fingertip's four strain channels, as HX711 counts at gain 128.

    ``seed`` selects the unit (its deviations) and its noise stream; ``variation=False`` gives
    the nominal unit. ``rate_sps`` (10 or 80) sets the HX711 noise. ``temperature_c`` is a
    constant or a function of time in seconds (array in, array out); by default the room's
    temperature over a session (:func:`~.realism.lab_temperature`) when the ``thermal``
    source is on, else the reference temperature (no drift). ``realism`` selects the
    imperfections (:class:`~.realism.Realism`: all on by default; ``Realism.ideal()`` is the
    earlier ideal sensor, ``Realism.bare()`` the closed-form beam and bridge). Forces are in
    newtons in the fingertip frame (the force the object applies to the fingertip), contact
    heights in millimetres below the nail tip,
    times in seconds. Hysteresis and creep keep state between calls: feed samples in time
    order, or call :meth:`reset`.
    """

    def __init__(self, seed: int | None = 0, *, params: FingertipParams | None = None,
                 variation: bool = True, rate_sps: int = 80,
                 temperature_c: Temperature | None = None,
                 realism: Realism | None = None) -> None:
        self.params = params or load()
        self.seed = seed
        self.realism = Realism() if realism is None else realism
        ss = np.random.SeedSequence(seed)
        unit_ss, noise_ss, real_ss = ss.spawn(3)
        self.unit = UnitVariation.draw(self.params, np.random.default_rng(unit_ss)) \
            if variation and self.realism.unit_spread else UnitVariation.nominal(self.params)
        self.rate_sps = rate_sps
        self.params.hx711.noise_v_rms(rate_sps)  # validates the rate
        self.realism_params = _realism.load()
        self.real = UnitRealism.draw(self.realism_params, self.realism,
                                     self.unit.shunt if self.realism.shunt else 0.0,
                                     np.random.default_rng(real_ss))
        if temperature_c is None:
            temperature_c = lab_temperature(self.realism_params, self.real,
                                            self.params.thermal.reference_c) \
                if self.realism.thermal and self.realism.thermal_response \
                else self.params.thermal.reference_c
        self.temperature_c: Temperature = temperature_c
        self._slow = SlowCreep(self.real.creep_fraction, self.real.creep_tau_s)
        self._noise_rng = np.random.default_rng(noise_ss)
        h = self.params.hysteresis
        self._radii = (np.arange(h.operators) + 0.5) / h.operators * h.radius_max_ue * 1e-6
        self.reset()

    # --- state ----------------------------------------------------------------------------

    def reset(self) -> None:
        """Back to the virgin, fully relaxed state (no load history)."""
        self._state = _State(np.zeros((4, len(self._radii))), np.zeros(4), None)
        self._slow.reset()

    def save_state(self) -> SensorState:
        """A copy of everything carried between calls (load history and the noise's draws)."""
        slow = self._slow
        return SensorState(self._state.copy(), slow.state.copy(), slow.t_last,
                           self._noise_rng.bit_generator.state)

    def restore_state(self, saved: SensorState) -> None:
        """Back to a :meth:`save_state` copy: the next calls give what they gave after it."""
        self._state = saved.strain.copy()
        self._slow.state, self._slow.t_last = saved.slow.copy(), saved.slow_t_last
        self._noise_rng.bit_generator.state = saved.noise

    # --- mechanics (stateless) ------------------------------------------------------------

    @property
    def flexural_rigidity_nm2(self) -> float:
        p, u = self.params, self.unit
        ratio = p.geometry.prism_core_side_mm / p.geometry.prism_side_mm
        return section_rigidity(u.prism_side_m, u.prism_side_m * ratio, u.modulus_pa,
                                p.materials.tpu_modulus_mpa * 1e6)

    @property
    def axial_rigidity_n(self) -> float:
        """EA of the section (PLA core + TPU shell)."""
        p, u = self.params, self.unit
        core = u.prism_side_m * p.geometry.prism_core_side_mm / p.geometry.prism_side_mm
        return u.modulus_pa * core ** 2 + p.materials.tpu_modulus_mpa * 1e6 * (
            u.prism_side_m ** 2 - core ** 2)

    def surface_strain(self, force_xy: np.ndarray, contact_height_mm: np.ndarray | float,
                       force_z: np.ndarray | float = 0.0) -> np.ndarray:
        """Axial strain eps_zz at each gauge centre, (N, 4): the beam model, no gauge."""
        f, zc = self._forces(force_xy, contact_height_mm)
        return self._surface(f, zc, np.broadcast_to(np.asarray(force_z, float), zc.shape))

    def _forces(self, force_xy, contact_height_mm) -> tuple[np.ndarray, np.ndarray]:
        f = np.atleast_2d(np.asarray(force_xy, dtype=float))
        if f.shape[-1] != 2:
            raise ValueError("force_xy must have shape (2,) or (N, 2)")
        zc = (self.params.geometry.nail_tip_z_mm
              - np.broadcast_to(np.asarray(contact_height_mm, float), f.shape[:1])) * 1e-3
        return f, zc

    def shunt_fraction(self, f: np.ndarray) -> np.ndarray:
        """Fraction of the moment carried past the prism, (N,)."""
        if not self.realism.shunt:
            return np.zeros(f.shape[0])
        b = self.params.base
        mag = np.hypot(f[:, 0], f[:, 1])
        phi = np.arctan2(f[:, 1], f[:, 0])
        k = self.unit.shunt * (1 + b.moment_shunt_threefold
                               * np.cos(3 * (phi - self.unit.shunt_phase_rad)))
        return np.clip(k + b.moment_shunt_per_newton * mag, 0.0, 0.5)

    def _surface(self, f: np.ndarray, zc: np.ndarray, fz: np.ndarray,
                 shear: list | None = None) -> np.ndarray:
        u = self.unit
        c = u.prism_side_m / 2
        ei = self.flexural_rigidity_nm2
        e_lat = u.gauge_lateral_m
        kept = 1 - self.shunt_fraction(f)
        feff = f * kept[:, None]
        fn = feff @ NORMALS.T                               # (N, 4) force along each normal
        ft = feff @ TANGENTS.T                              # (N, 4) force along each face
        zg = self.params.geometry.gauge_center_z_mm * 1e-3 + u.gauge_dz_m
        lever = zc[:, None] - zg[None, :]
        eps = -(c * fn + e_lat * ft) * lever / ei
        eps = eps - fz[:, None] / self.axial_rigidity_n
        if self.realism.contact and np.any(fz):
            point = c * NORMALS + e_lat[:, None] * TANGENTS
            eps = eps + eccentric_strain(
                f, fz * kept, point, self.realism_params.contact.surface_radius_mm * 1e-3, ei)
        if shear is not None:
            g_mod = u.modulus_pa / (2 * (1 + self.params.materials.pla_poisson))
            i_sec = ei / u.modulus_pa
            shear.append(ft * (c ** 2 - e_lat ** 2) / (2 * i_sec * g_mod))
        return eps

    def gauge_strain(self, eps: np.ndarray, gamma: np.ndarray) -> np.ndarray:
        """Strain read by each gauge: misalignment, Poisson, shear, transverse sensitivity."""
        u, p = self.unit, self.params
        nu = p.materials.pla_poisson
        th = u.gauge_angle_rad
        cs, sn = np.cos(th), np.sin(th)
        eps_t = -nu * eps
        along = eps * cs ** 2 + eps_t * sn ** 2 + gamma * sn * cs
        across = eps * sn ** 2 + eps_t * cs ** 2 - gamma * sn * cs
        return u.glue_transfer * (along + p.gauge.transverse_sensitivity * across)

    # --- dynamics (stateful) --------------------------------------------------------------

    def _hysteresis(self, eps: np.ndarray, update: bool) -> np.ndarray:
        if not self.realism.hysteresis or eps.shape[0] == 0:
            return eps
        st = self._state
        out = np.empty_like(eps)
        p0 = st.play
        for a in range(0, eps.shape[0], CHUNK):            # bounded (N, 4, K) temporaries
            e = eps[a:a + CHUNK]
            play = play_scan(e[:, :, None], self._radii, p0)
            p0 = play[-1].copy()
            out[a:a + CHUNK] = e + self.unit.hysteresis_gain * (play - e[:, :, None]).mean(axis=2)
        if update:
            st.play = p0
        return out

    def _creep(self, eps: np.ndarray, t: np.ndarray, update: bool) -> np.ndarray:
        if not self.realism.short_creep or eps.shape[0] == 0:
            return eps
        st = self._state
        dt = np.diff(t, prepend=t[0] if st.t_last is None else st.t_last)
        if np.any(dt < 0):
            raise ValueError("times must not go backwards")
        out = np.empty_like(eps)
        x0 = st.creep
        for k in range(0, eps.shape[0], CHUNK):
            a = np.exp(-dt[k:k + CHUNK, None] / self.unit.creep_tau_s[None, :])
            x = affine_scan(a, (1 - a) * eps[k:k + CHUNK], x0)
            x0 = x[-1].copy()
            out[k:k + CHUNK] = eps[k:k + CHUNK] + self.unit.creep_fraction * x
        if update:
            st.creep = x0
        return out

    def temperature_at(self, t: np.ndarray) -> np.ndarray:
        tc = self.temperature_c
        if callable(tc):
            return np.broadcast_to(np.asarray(tc(t), dtype=float), t.shape)
        return np.full(t.shape, float(tc))

    # --- electrical -----------------------------------------------------------------------

    def bridge_volts(self, strain: np.ndarray, temperature_c: np.ndarray | None = None
                     ) -> np.ndarray:
        """Exact quarter-bridge output for the gauge strain (N, 4), in volts."""
        p, u = self.params, self.unit
        gf = u.gauge_factor
        r_lead = p.bridge.lead_resistance_ohm
        if self.realism.offsets:
            r_g0, rc = u.gauge_ohm, u.completion_ohm
        else:
            r_g0, rc, r_lead = np.full(4, p.gauge.resistance_ohm), \
                np.full((4, 3), p.bridge.completion_ohm), 0.0
        if temperature_c is not None and self.realism.thermal_response:
            dt = temperature_c[:, None] - p.thermal.reference_c
            gf = gf * (1 + p.gauge.gauge_factor_tc_per_k * dt)
            r_lead = r_lead * (1 + 0.0039 * dt)  # copper
            rc = rc * (1 + self.real.completion_tcr_per_k * dt[:, :, None])
        r_g = r_g0 * (1 + gf * strain) + r_lead
        v_ex = p.hx711.excitation_v
        rc = np.broadcast_to(rc, (*r_g.shape, 3))
        return v_ex * (r_g / (r_g + rc[..., 0]) - rc[..., 1] / (rc[..., 1] + rc[..., 2]))

    def noise_counts_rms(self, rate_sps: int | None = None) -> np.ndarray:
        """Input noise of each channel in counts (rms)."""
        h = self.params.hx711
        return h.noise_v_rms(rate_sps or self.rate_sps) * h.counts_per_volt * self.unit.noise_scale

    # --- public paths ---------------------------------------------------------------------

    def counts(self, force_xy: Sequence[float] | np.ndarray, contact_height_mm: float,
               t: float, force_z: float = 0.0) -> np.ndarray:
        """One conversion at time ``t`` (s): the four channels' counts, int64 (4,)."""
        return self.counts_batch(np.asarray(force_xy, float)[None, :], [contact_height_mm],
                                 [t], force_z=[force_z])[0]

    def counts_batch(self, force_xy: np.ndarray, contact_height_mm: np.ndarray | float,
                     t: np.ndarray, force_z: np.ndarray | float = 0.0, *,
                     update_state: bool = True, rate_sps: int | None = None) -> np.ndarray:
        """Conversions at times ``t`` (N,), in order, continuing from the current state:
        (N, 4) int64 counts, rounded and saturated at the 24-bit limits."""
        h = self.params.hx711
        raw = self.raw_counts_batch(force_xy, contact_height_mm, t, force_z,
                                    update_state=update_state, rate_sps=rate_sps)
        return np.clip(np.rint(raw), h.count_min, h.count_max).astype(np.int64)

    def raw_counts_batch(self, force_xy: np.ndarray, contact_height_mm: np.ndarray | float,
                         t: np.ndarray, force_z: np.ndarray | float = 0.0, *,
                         update_state: bool = True, rate_sps: int | None = None
                         ) -> np.ndarray:
        """As :meth:`counts_batch` but unrounded and unsaturated (what the chip converts)."""
        return self.simulate_batch(force_xy, contact_height_mm, t, force_z,
                                   update_state=update_state, rate_sps=rate_sps).counts_f

    def simulate_batch(self, force_xy, contact_height_mm, t, force_z=0.0, *,
                       update_state: bool = True, rate_sps: int | None = None) -> _Batch:
        """The whole chain with its intermediate signals (see :class:`_Batch`)."""
        f, zc = self._forces(force_xy, contact_height_mm)
        t = np.asarray(t, dtype=float).reshape(-1)
        if t.shape[0] != f.shape[0]:
            raise ValueError("force_xy and t differ in length")
        fz = np.broadcast_to(np.asarray(force_z, float), t.shape)
        shear: list[np.ndarray] = []
        surface = self._surface(f, zc, fz, shear)
        gauge = self.gauge_strain(surface, shear[0])
        mech = self._creep(self._hysteresis(gauge, update_state), t, update_state)
        mech = self._slow.apply(mech, t, update_state)
        temp = None
        total = mech
        if self.realism.thermal_response:
            temp = self.temperature_at(t)
            dt = temp[:, None] - self.params.thermal.reference_c
            total = mech * (1 + self.unit.span_tc_per_k * dt) \
                + self.unit.apparent_strain_per_k * dt
        if self.realism.offsets:
            total = total + self.unit.prestrain
        volts = self.bridge_volts(total, temp)
        if self.realism.offsets:
            volts = volts + self.unit.hx711_offset_v
        if temp is not None:  # the HX711's own temperature coefficients
            volts = (volts + self.real.offset_drift_v_per_k * dt) \
                * (1 + self.real.gain_drift_per_k * dt)
        counts_f = volts * self.params.hx711.counts_per_volt
        if self.realism.hx711_noise:
            counts_f = counts_f + self._noise_rng.standard_normal(counts_f.shape) \
                * self.noise_counts_rms(rate_sps)
        if update_state and t.shape[0]:
            self._state.t_last = float(t[-1])
        return _Batch(surface, gauge, mech, total, volts, counts_f)

    def as_source(self, scene, t0_us: int = 0, rate_sps: int | None = None,
                  lookahead: int = LOOKAHEAD) -> LookaheadSource:
        """The callable :class:`~fingertip.sim.VirtualFirmware` takes as ``source``.

        Device time ``t_us`` -> the four chips' inputs in counts at gain 128, unrounded and
        unclipped (the firmware rounds, scales by gain / 128 and saturates). Scene time is
        ``(t_us - t0_us) / 1e6``; the sensor's own clock (creep, temperature) is device time.
        ``scene`` is anything with ``forces(t)`` (every scene has it, whatever it needs).
        With ``rate_sps`` None the HX711 noise follows the interval between calls (>= 50 ms:
        10 SPS, else 80 SPS). Calls must come in time order (hysteresis and creep). The
        physics runs ``lookahead`` conversions at a time (:mod:`.source`).
        """
        return LookaheadSource(self, scene, t0_us, rate_sps, lookahead)


def cap_deflection_m(params: FingertipParams, force_n: float, contact_height_mm: float = 0.0
                     ) -> dict[str, float]:
    """Static deflections for a lateral force on the cap (nominal unit), for design checks.

    ``nail``: lateral displacement of the nail tip (prism bending + base rotation);
    ``gap_closure``: largest relative displacement between the cap's inner wall and the
    prism (what the 1 mm gap must accommodate).
    """
    g = params.geometry
    ei = params.flexural_rigidity_nm2
    length = g.prism_length_mm * 1e-3
    zc = (g.nail_tip_z_mm - contact_height_mm) * 1e-3
    zt = g.nail_tip_z_mm * 1e-3
    m0 = force_n * (zc - length)
    v_top = force_n * length ** 3 / (3 * ei) + m0 * length ** 2 / (2 * ei)
    slope = force_n * length ** 2 / (2 * ei) + m0 * length / ei
    base_rot = force_n * zc / params.base.rotational_stiffness_nm_per_rad
    nail = v_top + slope * (zt - length) + base_rot * zt
    # Cap (rigid, fixed to the prism top) against the prism at height z: largest at the root.
    closure = abs(v_top - slope * length)
    return {"nail": nail, "gap_closure": closure, "base_rotation_rad": base_rot}
