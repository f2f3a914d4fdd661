"""What a fingertip pressed on a box hears of its contents: MuJoCo's contacts into the piezo.

After every physics step (a :class:`~.robot.MujocoWorld` update) the contacts between each
box's contents and its own walls, floor, roof and tray are read from ``data.contact``:

- a **new** item-wall contact is an impact: the item's speed towards the wall along the
  contact normal just before the step (its velocity relative to the box's), the item's mass
  and the impact's duration give the force on the wall (:func:`impact_pulse_n`, today's
  world's formula: momentum over a half sine, times the wall's transmission to the nail).
  A screw's impact rings at the screw's own two frequencies (drawn per screw, as the world
  draws them); a rubber band's is a soft thud (one duration per box, as the world's);
- a **persisting** contact that slides ticks: a screw rolling or sliding on the cardboard
  makes one tick per ``RATTLE_MM`` of slip (Poisson), each of the world's rattle size;
- the grip creaks faintly with the box's acceleration (the world's creak, scaled by the
  box's measured horizontal acceleration over the paper's shake's peak).

How it reaches the fingertip: only while the listening fingertip's deepest contact is on that
box (a nail on the other box, or in the air, hears nothing of it), scaled by that contact's
normal force now (:func:`grip_transmission`: the harder the nail presses on the wall, the
better it couples), through the box walls' modes and the content's low-pass
(``BOX_WALL_MODES``, ``BOX_LOWPASS_HZ``) into the same piezo chain as the nail's own contact
(a :class:`~.piezo.Path`). Item-on-item knocks are not heard: their force reaches the wall
only through the items that touch it, whose contacts are counted.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .project import (
    BAND_PULSE_S,
    BOX_LOWPASS_HZ,
    BOX_WALL_MODES,
    CREAK_N,
    RATTLE_N,
    RATTLE_PULSE_S,
    SCREW_PULSE_S,
    SCREW_RING_GAIN,
    SCREW_RING_HZ,
    grip_transmission,
    half_sine,
    impact_pulse_n,
    screw_ring,
)
from .sensor import FingertipSensor

RATTLE_MM = 4.0
"""Slip of a screw on the cardboard per rattle tick (mm): at the paper's shake, 2-4 ticks per
screw per second of shaking (seeds 1 and 2), of the order of the world's 5."""
MIN_APPROACH_M_S = 0.002
"""A remade contact slower than this is a resting item's contact flickering, not an impact."""
CREAK_REF_M_S2 = 0.05 * (2 * math.pi * 0.67) ** 2
"""The paper's shake's peak acceleration (5 cm at 0.67 Hz): the world's creak is full there."""
ACCEL_TAU_S = 0.02


class _Box:
    def __init__(self, model, info: dict, path, rng: np.random.Generator, fs: int) -> None:
        self.content = info["content"]
        self.geoms = np.asarray(info["geoms"], int)
        self.items = np.asarray(info["items"], int)
        self.dof = int(model.jnt_dofadr[model.body_jntadr[info["body"]]])
        self.item_dof = np.array([int(model.jnt_dofadr[model.body_jntadr[model.geom_bodyid[g]]])
                                  for g in self.items], int).reshape(-1)
        self.path = path
        k = len(self.items)
        if self.content == "screws":
            ring = screw_ring(rng.uniform(*SCREW_RING_HZ, (k, 2)), fs) * SCREW_RING_GAIN[0]
            pulse = half_sine(SCREW_PULSE_S, fs)
            ring[:, :len(pulse)] += pulse
            self.kernels = list(ring)
            self.duration = SCREW_PULSE_S
        else:
            self.duration = float(rng.uniform(*BAND_PULSE_S))
            self.kernels = [half_sine(self.duration, fs)] * k
        self.tick = half_sine(RATTLE_PULSE_S, fs)
        self.pairs: set[int] = set()
        self.accel = 0.0
        self.impacts = 0
        self.ticks = 0


class BoxSound:
    """The contents of ``boxes`` (``scene.info["boxes"]`` of :func:`~.boxes.box_pair`) heard
    by ``sensor`` (fidelity ``full``). Call :meth:`update` after every step (the world's
    ``updates`` list does)."""

    def __init__(self, model, data, boxes: Sequence[dict], sensor: FingertipSensor,
                 seed: int = 0) -> None:
        if sensor.piezo is None:
            raise ValueError("the listening fingertip needs fidelity 'full' (audio)")
        self.m, self.d, self.sensor = model, data, sensor
        rng = np.random.default_rng(np.random.SeedSequence([seed, 0x50D]))
        self.rng = rng
        fs = sensor.piezo.fs
        self.boxes = [_Box(model, b, sensor.piezo.add_path(BOX_LOWPASS_HZ[b["content"]],
                                                           BOX_WALL_MODES), rng, fs)
                      for b in boxes]
        self.wall_of = np.full(model.ngeom, -1, int)
        self.item_of = np.full(model.ngeom, -1, int)
        self.item_box = np.full(model.ngeom, -1, int)
        for i, b in enumerate(self.boxes):
            self.wall_of[b.geoms] = i
            self.item_of[b.items] = np.arange(len(b.items))
            self.item_box[b.items] = i
        self._vel = self._velocities()

    def _velocities(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """Per box: its linear velocity and its items' (world frame, m/s)."""
        qv = self.d.qvel
        out = []
        for b in self.boxes:
            idx = b.item_dof[:, None] + np.arange(3)
            out.append((qv[b.dof:b.dof + 3].copy(), qv[idx].reshape(-1, 3).copy()))
        return out

    def heard_by(self) -> tuple[int, float]:
        """The box the listening fingertip presses on (-1: none) and its normal force (N)."""
        t = self.sensor.touch
        if not t.found or t.other_geom < 0:
            return -1, 0.0
        return int(self.wall_of[t.other_geom]), float(t.normal_n)

    def update(self, data) -> None:
        d = data
        dt = self.m.opt.timestep
        n = d.ncon
        vel = self._velocities()
        listening, normal = self.heard_by()
        if n:
            g = np.asarray(d.contact.geom[:n], int).reshape(-1, 2)
            frame = np.asarray(d.contact.frame[:n]).reshape(-1, 9)
            first_item = self.item_box[g[:, 0]] >= 0
            item = np.where(first_item, g[:, 0], g[:, 1])
            wall = np.where(first_item, g[:, 1], g[:, 0])
            ib = self.item_box[item]
            ok = (ib >= 0) & (ib == self.wall_of[wall])
        else:
            ok = np.zeros(0, bool)
        for i, b in enumerate(self.boxes):
            if n:
                rows = np.flatnonzero(ok & (ib == i))
                keys = item[rows] * self.m.ngeom + wall[rows]
            else:
                rows, keys = np.zeros(0, int), np.zeros(0, int)
            now = set(keys.tolist())
            box_v, items_v = vel[i]
            a = np.linalg.norm(box_v[:2] - self._vel[i][0][:2]) / dt
            b.accel += min(1.0, dt / ACCEL_TAU_S) * (a - b.accel)
            heard = listening == i
            gain = grip_transmission(normal) if heard else 0.0
            t = d.time
            if heard:
                b.path.noise(t, CREAK_N * gain * b.accel / CREAK_REF_M_S2)
            seen: set[int] = set()
            for r, key in zip(rows.tolist(), keys.tolist(), strict=True):
                if key in seen:
                    continue
                seen.add(key)
                k = int(self.item_of[item[r]])
                nrm = frame[r, :3]
                if key not in b.pairs:
                    rel = self._vel[i][1][k] - self._vel[i][0]     # just before the step
                    v = abs(float(rel @ nrm))
                    if v < MIN_APPROACH_M_S:
                        continue
                    b.impacts += 1
                    if heard:
                        amp = float(impact_pulse_n(b.content, np.array([v]), b.duration,
                                                   gain)[0])
                        b.path.event(t - dt, amp, b.kernels[k])
                elif b.content == "screws":
                    rel = items_v[k] - box_v
                    slip = float(np.linalg.norm(rel - (rel @ nrm) * nrm)) * 1e3
                    ticks = int(self.rng.poisson(slip * dt / RATTLE_MM)) if slip > 1.0 else 0
                    b.ticks += ticks
                    if heard:
                        for _ in range(ticks):
                            amp = RATTLE_N * gain * math.exp(0.5 * self.rng.standard_normal())
                            b.path.event(t - dt * self.rng.uniform(), amp, b.tick)
            b.pairs = now
        self._vel = vel
