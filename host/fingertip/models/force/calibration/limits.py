"""The limits a calibration dataset and its fit are held to (channels,
conditioning, rows, saturation, directions, dead channels), each with the reason for its value."""
from __future__ import annotations

from collections.abc import Callable

CHANNELS = 4
MAX_CONDITION = 1e6
"""Refusal threshold for the condition number of the standardised affine design [z, 1].
A working fingertip stays below about 2e4: opposite gauges read almost opposite signals
(correlation about -0.99, condition about 150 on the virtual units), but each HX711 adds its
own noise (25-45 counts against a spread of about 1.5e5), which bounds the condition number
by about sqrt(5) x spread / noise even for perfectly matched gauges; 1e6 would take forces
near the ADC's limits. Above it, channels are copies or exact combinations of each other
(two inputs wired to one bridge, a channel duplicated in software)."""
MIN_ROWS = 40
MAX_SATURATED_FRACTION = 0.05
MIN_DIRECTION_RATIO = 0.05
"""Smallest/largest singular value of the (loaded) force vectors: below it the forces point
in one direction only (one angle), and the four channels cannot be mapped to two axes."""
MIN_RESPONSE_R2 = 0.2
"""A channel whose variance is less than this much explained by (Fx, Fy, |F|) is dead."""
Progress = Callable[[str], None]
