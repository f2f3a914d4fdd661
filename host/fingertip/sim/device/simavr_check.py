"""``fingertip check`` against the real firmware in simavr: the guide schedules each press as
input rows of the simulated HX711s (the pattern a press makes on the four bridges), so the
check's presses, mapping and polarity run through the firmware's real bit-banged reads."""
from __future__ import annotations

import numpy as np

from .simavr import FirmwareSim

PRESS_COUNTS = 2e5
CROSS = 0.08
"""Cross-talk of a press onto the two side faces (fraction)."""


def press_pattern(face: int) -> np.ndarray:
    """Change of each channel's input for a press on ``face`` (its gauge stretched, the
    opposite one compressed, a little on the sides)."""
    d = np.zeros(4)
    d[face] = PRESS_COUNTS
    d[(face + 2) % 4] = -PRESS_COUNTS
    d[(face + 1) % 4] = CROSS * PRESS_COUNTS
    d[(face + 3) % 4] = -CROSS * PRESS_COUNTS
    return d


class SimavrGuide:
    """Presses as scheduled input rows: ramp 0.25 s, hold 0.8 s, release 0.25 s, starting
    ``lead_s`` after the request. ``rest``: the bridges' inputs at rest (counts)."""

    interactive = False
    simulated = True

    def __init__(self, sim: FirmwareSim, rest, lead_s: float = 0.25) -> None:
        self.sim = sim
        self.rest = np.asarray(rest, float)
        self.lead_s = lead_s
        self.acted_at_s: float | None = None
        """The firmware's time when the last step was asked (the check records from there)."""

    def press(self, face: int, label: str) -> bool:
        now = self.sim.time_us()
        self.acted_at_s = (now - self.sim.boot_us) * 1e-6
        t0 = now + self.lead_s * 1e6
        d = press_pattern(face)
        knots = [(0.0, 0.0), (0.25, 1.0), (1.05, 1.0), (1.3, 0.0)]
        times = np.arange(0.0, 1.3 + 1e-9, 0.01)
        level = np.interp(times, [k[0] for k in knots], [k[1] for k in knots])
        rows = [self.rest + lv * d for lv in level]
        self.sim.rows([t0 + t * 1e6 for t in times], rows)
        return True

    def tap(self, count: int) -> bool:
        return False  # no piezo on the Uno: the check skips its step
