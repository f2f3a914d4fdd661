"""The paper's calibration sweep, simulated (section "Force estimation with strain gauges").

A 3 mm cylindrical indenter steps into the fingertip in the XY plane, 1.5 mm per step up to
30 mm of travel, then retracts along the same path, pausing 8 s at each step before a
reading is recorded; repeated for angles -50..50 degrees (10 degree steps) and contact
heights 0..5 mm (1 mm steps) in random order. The true force comes from the F/T sensor.

Travel is robot displacement, not skin indentation: the indenter starts clear of the
fingertip and touches it after ``contact_mm`` (random per trial, 2-8 mm); the force then
grows as F_end * ((d - d_c) / (travel - d_c))^1.3 (skin and base stiffening), reaching
F_end (0.9-1.0 x ``max_force_n``) at full travel. The readings carry the sensor's
hysteresis and creep, because the whole trajectory (moves and pauses) is simulated in order.

With the sensor's ``contact`` error source (:mod:`.realism`) each trial touches at the
nominal height plus a spread and in the nominal direction plus a spread (the F/T truth is
the real force; the logged angle and height stay nominal). With ``skin`` the silicone relaxes
under each held step (the force overshoots, then settles) and its shear carries a vertical
friction force as the cap tilts on its base, whose moment the gauges feel; the 2D
calibration's truth leaves it out, as the paper's does.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..physics.realism import Realism, RealismParams
from ..physics.strain import VirtualStrainSensor

COLUMNS = ("c0", "c1", "c2", "c3", "fx_n", "fy_n", "angle_deg", "height_mm")


@dataclass
class Sweep:
    counts: np.ndarray
    """(N, 4) int64 counts (gain 128)."""
    fx: np.ndarray
    fy: np.ndarray
    angle_deg: np.ndarray
    height_mm: np.ndarray
    displacement_mm: np.ndarray
    loading: np.ndarray
    """True on the way in, False on the way out."""
    trial: np.ndarray
    step: np.ndarray
    t_us: np.ndarray
    unit_seed: int | None
    rest_counts: np.ndarray | None = None
    """(N, 4) int64: the reading at rest just before the row's trial touched (the indenter
    clear of the skin), what a re-tare before each contact would take; None if not known."""

    def __len__(self) -> int:
        return len(self.fx)

    def rows(self) -> np.ndarray:
        """(N, 8) float64: c0..c3, Fx, Fy, angle, height (see ``COLUMNS``)."""
        return np.column_stack([self.counts.astype(float), self.fx, self.fy, self.angle_deg,
                                self.height_mm])

    def select(self, mask: np.ndarray) -> Sweep:
        return Sweep(*(getattr(self, k)[mask] for k in (
            "counts", "fx", "fy", "angle_deg", "height_mm", "displacement_mm", "loading",
            "trial", "step", "t_us")), self.unit_seed,
            None if self.rest_counts is None else self.rest_counts[mask])


def force_at(displacement_mm: np.ndarray, contact_mm: float, travel_mm: float,
             end_force_n: float) -> np.ndarray:
    u = np.clip((np.asarray(displacement_mm, float) - contact_mm) / (travel_mm - contact_mm),
                0, 1)
    return end_force_n * u ** 1.3


def calibration_sweep(sensor: VirtualStrainSensor | None = None, *, seed: int = 0,
                      angles_deg: Sequence[float] = tuple(range(-50, 51, 10)),
                      heights_mm: Sequence[float] = (0, 1, 2, 3, 4, 5),
                      step_mm: float = 1.5, travel_mm: float = 30.0, pause_s: float = 8.0,
                      move_s: float = 0.5, rest_s: float = 5.0, samples_per_step: int = 1,
                      max_force_n: float = 5.0, randomize: bool = True, rate_sps: int = 80,
                      t0_us: int = 0, realism: Realism | None = None) -> Sweep:
    """Simulate the paper's sweep on ``sensor`` (default: unit ``seed``).

    ``seed`` also draws the trial order and each trial's contact point and end force.
    ``samples_per_step`` readings are recorded at the end of each pause, one HX711 period
    apart. ``realism``: the scene's error sources (``contact``, ``skin``; default: the
    sensor's). Returns one row per reading.
    """
    if sensor is None:
        sensor = VirtualStrainSensor(seed, rate_sps=rate_sps, realism=realism)
    realism = sensor.realism if realism is None else realism
    rp = sensor.realism_params
    rng = np.random.default_rng(np.random.SeedSequence([seed if seed is not None else 0, 7]))
    trials = [(a, h) for a in angles_deg for h in heights_mm]
    if randomize:
        trials = [trials[i] for i in rng.permutation(len(trials))]
    n_in = int(round(travel_mm / step_mm))
    disp = np.concatenate([np.arange(1, n_in + 1), np.arange(n_in - 1, -1, -1)]) * step_mm
    loading = np.arange(len(disp)) < n_in
    period = 1.0 / sensor.rate_sps

    # Points inside each pause (s after the move) where the skin's relaxation is sampled.
    relax_at = np.array([0.5, 2.0]) if realism.skin else np.zeros(0)
    t_parts, f_parts, a_parts, h_parts, rec_parts, meta = [], [], [], [], [], []
    z_parts, zf_parts = [], []
    t = t0_us * 1e-6
    for k, (angle, height) in enumerate(trials):
        contact = rng.uniform(2.0, 8.0)
        end_force = max_force_n * rng.uniform(0.9, 1.0)
        # Drawn whatever the flags, so turning one source off leaves the others' draws alone.
        dh, da = rng.normal(0.0, 1.0, 2)
        true_h = height + (dh * rp.contact.height_sd_mm if realism.contact else 0.0)
        true_a = angle + (da * rp.contact.angle_sd_deg if realism.contact else 0.0)
        prev = np.concatenate([[0.0], disp[:-1]])
        # Per step: mid-move, end of move, then the recorded readings at the pause's end.
        t_rest = t + rest_s
        starts = t_rest + np.arange(len(disp)) * (move_s + pause_s)
        rec_off = move_s + pause_s - period * np.arange(samples_per_step)[::-1]
        tt = np.column_stack([starts + move_s / 2, starts + move_s,
                              starts[:, None] + move_s + relax_at[None, :],
                              starts[:, None] + rec_off[None, :]])
        n_pts = tt.shape[1]
        dd = np.repeat(disp[:, None], n_pts, 1)
        dd[:, 0] = (prev + disp) / 2
        since = np.maximum(tt - (starts + move_s)[:, None], 0.0)   # since the step ended
        rec = np.zeros(tt.shape, bool)
        rec[:, n_pts - samples_per_step:] = True
        tt = np.concatenate([[t_rest - period], tt.ravel()])
        dd = np.concatenate([[0.0], dd.ravel()])
        since = np.concatenate([[1e9], since.ravel()])
        rec = np.concatenate([[False], rec.ravel()])
        mag = force_at(dd, contact, travel_mm, end_force)
        fz = np.zeros_like(mag)
        if realism.skin:
            mag, fz = _skin(mag, since, pause_s, rp, sensor, true_h)
        t_parts.append(tt)
        f_parts.append(mag)
        z_parts.append(np.full(len(tt), true_a))
        zf_parts.append(fz)
        a_parts.append(np.full(len(tt), float(angle)))
        h_parts.append(np.full(len(tt), float(true_h)))
        rec_parts.append(rec)
        steps = np.repeat(np.arange(len(disp)), samples_per_step)
        meta.append((np.full(len(steps), k), steps, disp[steps], loading[steps]))
        t = starts[-1] + move_s + pause_s

    tt = np.concatenate(t_parts)
    mag = np.concatenate(f_parts)
    hh = np.concatenate(h_parts)
    rec = np.concatenate(rec_parts)
    rad = np.radians(np.concatenate(z_parts))
    fxy = np.column_stack([mag * np.cos(rad), mag * np.sin(rad)])
    counts = sensor.counts_batch(fxy, hh, tt, np.concatenate(zf_parts))
    trial, step, d, load = (np.concatenate(x) for x in zip(*meta, strict=True))
    # Each trial's first point is the rest reading before its first move (force zero).
    first = np.cumsum([0] + [len(x) for x in t_parts[:-1]])
    rest = counts[first][trial]
    nominal_h = np.concatenate([np.full(len(m[0]), float(h)) for m, (_, h)
                                in zip(meta, trials, strict=True)])
    nominal_a = np.concatenate([np.full(len(m[0]), float(a)) for m, (a, _)
                                in zip(meta, trials, strict=True)])
    return Sweep(counts[rec], fxy[rec, 0], fxy[rec, 1], nominal_a, nominal_h, d, load, trial,
                 step, np.rint(tt[rec] * 1e6).astype(np.int64), sensor.seed, rest)


def _skin(mag: np.ndarray, since_s: np.ndarray, pause_s: float, rp: RealismParams,
          sensor: VirtualStrainSensor, height_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """The silicone skin under a held indentation: force and vertical friction force.

    Position control: right after a step the skin carries its unrelaxed stiffness, so the
    force is higher, G(t)/G(pause) times the force at the reading (which keeps the sweep's
    force law at the readings), and settles during the pause. The cap tilts on its base by
    F z_c / k_rot; the contact point, at the fingertip's side radius r, rises by r theta
    against the indenter, and the
    skin's shear over the indenter's patch carries Fz = k_s G(t)/G(0) r theta (compressive),
    at most the friction limit mu F. Upper bound: the whole of it relaxes after each step."""
    sk = rp.skin
    g = sk.relaxation(since_s)
    mag = mag * g / sk.relaxation(pause_s)
    p = sensor.params
    zc = (p.geometry.nail_tip_z_mm - height_mm) * 1e-3
    theta = mag * zc / p.base.rotational_stiffness_nm_per_rad
    fz = sk.shear_stiffness_n_per_m * g * rp.contact.surface_radius_mm * 1e-3 * theta
    return mag, np.minimum(fz, sk.friction * mag)
