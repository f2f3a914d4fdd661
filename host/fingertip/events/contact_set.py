"""One contact detector per finger of a hand: fused piezo + force, or force frames alone.

A recipe feeds it what the hand delivers (each finger's force magnitude per frame, each
finger's piezo blocks when it has them) and gets ``(finger, event)`` pairs back, in the
order the data arrived. The detectors are :mod:`.reflex`'s: :class:`~.reflex.FusedContact`
(``mode="fused"``) or :class:`~.reflex.ForceOnlyContact` (``mode="force"``).
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .reflex import ForceOnlyContact, FusedConfig, FusedContact, ReflexEvent

MODES = ("fused", "force")
GATE_S = 0.08
"""How long the piezos are gated when the hand starts a move (see
:meth:`~.reflex.FusedContact.motion`)."""

FingerEvent = tuple[str, ReflexEvent]


class ContactSet:
    """Contact and release per finger (``mode`` "fused" needs the piezos' sample rate)."""

    def __init__(self, fingers: Sequence[str], mode: str = "fused", fs: float | None = None,
                 cfg: FusedConfig | None = None) -> None:
        if mode not in MODES:
            raise ValueError(f"contact mode must be one of {MODES}, not {mode!r}")
        if not fingers:
            raise ValueError("no fingers")
        if mode == "fused" and (fs is None or fs <= 0):
            raise ValueError("fused contact needs the piezos' sample rate fs > 0")
        self.mode = mode
        self.fingers = list(fingers)
        self.fs = fs
        cfg = cfg or FusedConfig()
        self._det: dict[str, FusedContact | ForceOnlyContact] = {
            f: FusedContact(float(fs), cfg) if mode == "fused"  # type: ignore[arg-type]
            else ForceOnlyContact(cfg.force) for f in self.fingers}

    @property
    def needs_audio(self) -> bool:
        return self.mode == "fused"

    def _check(self, finger: str) -> FusedContact | ForceOnlyContact:
        try:
            return self._det[finger]
        except KeyError:
            raise ValueError(f"no finger {finger!r}; fingers: {self.fingers}") from None

    def feed_force(self, finger: str, t: float, force_n: float, now: float | None = None
                   ) -> list[FingerEvent]:
        """One force frame of ``finger`` (tared magnitude, newtons) of time ``t``."""
        return [(finger, ev) for ev in self._check(finger).feed_force(t, force_n, now)]

    def feed_audio(self, finger: str, samples: np.ndarray, t0: float,
                   now: float | None = None) -> list[FingerEvent]:
        """A block of ``finger``'s piezo samples from ``t0`` (ignored in force mode)."""
        det = self._check(finger)
        if not isinstance(det, FusedContact):
            return []
        return [(finger, ev) for ev in det.feed_audio(samples, t0, now)]

    def motion(self, t: float, fingers: Sequence[str] | None = None,
               guard_s: float = GATE_S) -> None:
        """The hand starts moving ``fingers`` (default all) at ``t``: their motors' noise
        must not be taken for touches."""
        for f in fingers if fingers is not None else self.fingers:
            det = self._check(f)
            if isinstance(det, FusedContact):
                det.motion(t, guard_s)
