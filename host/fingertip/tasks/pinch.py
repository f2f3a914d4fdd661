"""The force-threshold pinch (the paper's tofu and potato-chip grasps).

One demonstration records the pinch force ``F_th`` (:func:`demonstrate_threshold`). Then
:func:`pinch` steps every finger closed, one increment per sensor frame, until that
finger's filtered force (a short moving average of the calibrated force magnitude) reaches
``F_th``; it then holds the force (re-closing a finger whose force sags) while the arm lifts.
It aborts to a safe state (arm stopped, fingers opened) on a force above ``max_force_n``, a
timeout, or a sensor fault (no frames, timeout/saturation bits, non-finite estimates).
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping

import numpy as np

from ..events.contact_set import ContactSet
from .approach import approach
from .grip import Grip, PinchConfig, PinchOutcome, PinchResult, SensorFault
from .interfaces import ContactSource, RobotArm, RobotHand, require

__all__ = ["PinchConfig", "PinchOutcome", "PinchResult", "SensorFault",
           "demonstrate_threshold", "pinch"]


def demonstrate_threshold(forces_n: Iterable[Mapping[str, float]], window: int = 4) -> float:
    """``F_th`` from one demonstration: per-finger force magnitudes, one mapping per frame,
    recorded while a person pinches the object as firmly as the task needs. Returns the
    median over fingers of each finger's plateau (the median of its filtered force over the
    frames where it is above half its peak)."""
    rows = list(forces_n)
    if not rows:
        raise ValueError("empty demonstration")
    plateaus = []
    for f in rows[0]:
        x = np.array([r[f] for r in rows], float)
        if len(x) >= window:
            x = np.convolve(x, np.ones(window) / window, mode="valid")
        peak = x.max()
        if peak > 0:
            plateaus.append(float(np.median(x[x >= peak / 2])))
    if not plateaus:
        raise ValueError("no force in the demonstration")
    return float(np.median(plateaus))


def pinch(hand: RobotHand, arm: RobotArm | None, cfg: PinchConfig,
          contact: ContactSource | None = None) -> PinchResult:
    """Close to ``cfg.f_th_n`` on every finger, then hold while the arm lifts.

    With ``cfg.approach_speed_mm_s`` the fingers first close at that speed until
    ``contact`` (default: force frames alone) reports each finger's touch
    (:func:`.approach.approach`); the hand must implement ``move`` (and ``read_audio``
    for a contact source that needs audio)."""
    grip = Grip(hand, cfg, arm=arm)
    if cfg.approach_speed_mm_s is not None:
        if contact is None:
            contact = ContactSet(grip.fingers, "force")
        require("the pinch's approach", hand, arm,
                hand_methods=("move", "read_audio") if contact.needs_audio else ("move",))
        if not grip.zero():
            return grip.result
        ar = approach(grip, cfg.approach_speed_mm_s, contact)
        grip.result.contacts = ar.contacts
        if not ar.ok:
            return grip.result
    if grip.close() and arm is not None:
        arm.slide_z(cfg.lift_mm, cfg.lift_speed_mm_s)
        grip.hold(arm.moving)
    return grip.result
