"""What one fingertip's contacts are this step, from MuJoCo's own ``contact`` sensors.

Two sensors per fingertip (:mod:`.attach`) do the per-contact work in C: ``net`` sums every
contact on the fingertip into one force (global frame) at the force-weighted centroid;
``near`` is the deepest contact with its normal and distance. Python reads their slices of
``d.sensordata`` (views, no copies). Only the slip needs more: the relative velocity of the
two bodies at the contact point (``mj_objectVelocity`` on each), and which geoms touch (the
nail or the skin, and the other geom's material), read from ``d.contact`` when the
fingertip touches something.

Sign: MuJoCo's contact sensor reports the force the fingertip's body exerts on the others;
the strain model wants the force the object applies to the fingertip, so it is negated here.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._require import mujoco
from .attach import AttachedFingertip


RESCAN = 16
"""Steps between scans of d.contact while the number of contacts stays the same."""


@dataclass
class Touch:
    """The deepest contact on the fingertip this step (``found`` False: nothing touches)."""

    found: bool = False
    normal_n: float = 0.0
    """Magnitude of the net force along the contact normal."""
    slip_mm_s: float = 0.0
    """Tangential speed of the other body over the fingertip at the contact point."""
    approach_mm_s: float = 0.0
    """Speed along the normal (closing or opening)."""
    nail: bool = False
    other_geom: int = -1
    depth_m: float = 0.0
    """Penetration of the deepest contact (>= 0)."""


class ContactReader:
    """Reads one attached fingertip's contacts from a compiled model and its data."""

    def __init__(self, model, data, tip: AttachedFingertip) -> None:
        mj = mujoco()
        self.mj, self.m, self.d, self.tip = mj, model, data, tip
        self.body = mj.mj_name2id(model, mj.mjtObj.mjOBJ_BODY, tip.body)
        if self.body < 0:
            raise ValueError(f"the model has no fingertip body {tip.body!r}: attach it to the "
                             "spec before compiling")
        self.is_tip = np.zeros(model.ngeom, bool)
        for g in tip.geoms:
            self.is_tip[mj.mj_name2id(model, mj.mjtObj.mjOBJ_GEOM, g)] = True
        self.nail = mj.mj_name2id(model, mj.mjtObj.mjOBJ_GEOM, tip.nail_geom)
        net = mj.mj_name2id(model, mj.mjtObj.mjOBJ_SENSOR, tip.net_sensor)
        near = mj.mj_name2id(model, mj.mjtObj.mjOBJ_SENSOR, tip.near_sensor)
        a, b = int(model.sensor_adr[net]), int(model.sensor_adr[near])
        sd = data.sensordata
        self.net_found, self.net_force, self.net_pos = sd[a:a + 1], sd[a + 1:a + 4], \
            sd[a + 4:a + 7]
        self.near_found, self.near_force, self.near_dist = sd[b:b + 1], sd[b + 1:b + 4], \
            sd[b + 4:b + 5]
        self.near_pos, self.near_normal = sd[b + 5:b + 8], sd[b + 8:b + 11]
        self.rot = data.xmat[self.body].reshape(3, 3)
        self.origin = data.xpos[self.body]
        self._v_tip = np.zeros(6)
        self._v_other = np.zeros(6)
        self._arm = np.zeros(3)
        self._spin = np.zeros(3)
        self._pair = (-1, False)
        self._pair_ncon, self._pair_age = -1, 0

    @property
    def touching(self) -> bool:
        return self.net_found[0] > 0

    def force_on_tip(self) -> np.ndarray:
        """Net contact force on the fingertip, global frame (N); zeros without contact."""
        return -self.net_force

    def to_tip(self, vec_world: np.ndarray) -> np.ndarray:
        """A global-frame vector in the fingertip's frame."""
        return vec_world @ self.rot

    def point_in_tip(self, point_world: np.ndarray) -> np.ndarray:
        """A global point in the fingertip's frame (m)."""
        return (point_world - self.origin) @ self.rot

    def _point_velocity(self, body: int, point: np.ndarray, buf: np.ndarray) -> np.ndarray:
        """Global velocity of ``body``'s material point at ``point`` (C calls, no numpy
        temporaries but one)."""
        mj = self.mj
        mj.mj_objectVelocity(self.m, self.d, mj.mjtObj.mjOBJ_BODY, body, buf, 0)
        mj.mju_sub3(self._arm, point, self.d.xpos[body])
        mj.mju_cross(self._spin, buf[:3], self._arm)
        return buf[3:] + self._spin

    def touch(self) -> Touch:
        """The deepest contact with its slip and approach speeds."""
        if self.net_found[0] <= 0:
            self._pair_ncon = -1
            return Touch()
        d = self.d
        # Which geoms touch changes only when the contact list does: scan d.contact then
        # (and every RESCAN steps), not every step.
        if d.ncon != self._pair_ncon or self._pair_age >= RESCAN:
            if not self._scan():
                return Touch()
        self._pair_age += 1
        other, nail = self._pair
        point, normal = self.near_pos, self.near_normal
        rel = self._point_velocity(self.body, point, self._v_tip)
        body = int(self.m.geom_bodyid[other])
        if body:
            rel = self._point_velocity(body, point, self._v_other) - rel
        else:
            rel = -rel
        vn = float(rel @ normal)
        slip2 = max(0.0, float(rel @ rel) - vn * vn)
        return Touch(True, abs(float(self.net_force @ normal)), slip2 ** 0.5 * 1e3,
                     abs(vn) * 1e3, nail, other, max(0.0, -float(self.near_dist[0])))

    def _scan(self) -> bool:
        """Find the deepest contact of the fingertip in d.contact: its other geom, and
        whether the nail carries it."""
        d = self.d
        geoms = d.contact.geom
        hits = self.is_tip[geoms]
        rows = np.flatnonzero(hits[:, 0] | hits[:, 1])
        if rows.size == 0:  # the sensor saw a contact the constraint list dropped
            return False
        r = rows[np.argmin(d.contact.dist[rows])] if rows.size > 1 else rows[0]
        side = 0 if hits[r, 0] else 1
        self._pair = (int(geoms[r, 1 - side]), int(geoms[r, side]) == self.nail)
        self._pair_ncon, self._pair_age = d.ncon, 0
        return True
