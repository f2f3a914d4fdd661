"""The strain sensor as the virtual firmware's inputs: device time in microseconds -> the four
chips' inputs in counts, computed a block of conversions ahead.

The device library asks for one conversion at a time. Run one at a time, the physics costs
numpy's per-call overhead on every sample (about 0.7 ms), which starved the virtual device
behind a pty at 4x speed on a busy host. The chips convert on a fixed period, so this source
predicts the next ``lookahead`` conversion times, runs the physics for all of them in one
batch, and serves them while the device asks for exactly those times and the scene still
gives exactly those forces. On any other request (a new rate, a gap, a load added to the
scene since the block was made) it winds the sensor back to the start of the block, replays
what it served, and starts a new block from the request. What it serves is therefore the
per-sample result, up to float rounding between a batch of one and a batch of many.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

LOOKAHEAD = 32
"""Conversions per block (400 ms at 80 SPS): 56 us a conversion against 680 us one at a time."""


class Sensor(Protocol):
    """What the source needs of :class:`~.strain.VirtualStrainSensor` (named here, not
    imported: the sensor builds its source, so importing it back would be a cycle)."""
    rate_sps: int

    def raw_counts_batch(self, force_xy: np.ndarray, contact_height_mm: np.ndarray,
                         t: np.ndarray, force_z: np.ndarray, *,
                         rate_sps: int | None = None) -> np.ndarray: ...

    def save_state(self) -> Any: ...

    def restore_state(self, saved: Any) -> None: ...


@dataclass
class _Block:
    t_us: np.ndarray            # (n,) predicted conversion times
    xy: np.ndarray              # (n, 2) the scene's forces at those times, when predicted
    height_mm: np.ndarray       # (n,)
    z: np.ndarray               # (n,)
    rate_sps: int
    values: list[tuple[float, ...]]
    start: Any                  # the sensor before the block (its save_state())
    served: int = 0


class LookaheadSource:
    """Callable ``t_us -> tuple`` of the four chips' inputs (unrounded, unclipped counts).

    Scene time is ``(t_us - t0_us) / 1e6``; the sensor's own clock is device time. With
    ``rate_sps`` None the HX711 noise follows the interval between calls (>= 50 ms: 10 SPS,
    else 80 SPS). Calls must come in time order. The sensor's state runs up to a block ahead
    of what was served, so a sensor feeds one source; ``lookahead=1`` computes each
    conversion on its own.
    """

    def __init__(self, sensor: Sensor, scene, t0_us: int = 0,
                 rate_sps: int | None = None, lookahead: int = LOOKAHEAD) -> None:
        if lookahead < 1:
            raise ValueError("lookahead must be at least 1")
        self.sensor = sensor
        self.scene = scene
        self.t0_us = t0_us
        self.rate_sps = rate_sps
        self.lookahead = lookahead
        self.blocks = 0
        """Batches run so far (the physics' calls)."""
        self.rewinds = 0
        """Blocks given up before their end (a scene change or an unexpected time)."""
        self._last: int | None = None
        self._block: _Block | None = None

    def _rate(self, period_us: int | None) -> int:
        if self.rate_sps is not None:
            return self.rate_sps
        if period_us is None:
            return self.sensor.rate_sps
        return 10 if period_us >= 50_000 else 80

    def _scene(self, t_us: np.ndarray):
        return self.scene.forces((t_us - self.t0_us) * 1e-6)

    def __call__(self, t_us: int) -> tuple[float, ...]:
        period = None if self._last is None else t_us - self._last
        rate = self._rate(period)
        b = self._block
        if b is not None and b.served < len(b.values):
            i = b.served
            if b.t_us[i] == t_us and b.rate_sps == rate:
                f = self._scene(np.array([t_us]))
                if (f.xy[0] == b.xy[i]).all() and f.height_mm[0] == b.height_mm[i] \
                        and f.z[0] == b.z[i]:
                    b.served += 1
                    self._last = t_us
                    return b.values[i]
            self._rewind(b)
        self._block = self._predict(t_us, period, rate)
        self._block.served = 1
        self._last = t_us
        return self._block.values[0]

    def _predict(self, t_us: int, period: int | None, rate: int) -> _Block:
        n = self.lookahead if period is not None and period > 0 else 1
        times = t_us + (period or 0) * np.arange(n, dtype=np.int64)
        f = self._scene(times)
        xy = np.array(f.xy, float).reshape(n, 2)
        height = np.broadcast_to(np.asarray(f.height_mm, float), (n,)).copy()
        z = np.broadcast_to(np.asarray(f.z, float), (n,)).copy()
        start = self.sensor.save_state()
        raw = self.sensor.raw_counts_batch(xy, height, times * 1e-6, z, rate_sps=rate)
        self.blocks += 1
        return _Block(times, xy, height, z, rate, [tuple(r) for r in raw.tolist()], start)

    def _rewind(self, b: _Block) -> None:
        """Back to the block's start, then run only what was served (same noise draws)."""
        self.rewinds += 1
        self.sensor.restore_state(b.start)
        k = b.served
        if k:
            self.sensor.raw_counts_batch(b.xy[:k], b.height_mm[:k], b.t_us[:k] * 1e-6, b.z[:k],
                                         rate_sps=b.rate_sps)
        self._block = None
