"""A calibration run on a virtual unit, with a reference F/T sensor beside it: random presses
from every direction, the fingertip's frames, the true forces and what the reference sensor
reports (its own delay, rate, noise, lost packets and arrival jitter). For tests and
benchmarks of the join without real time; :class:`~.rdt_server.RdtServer` does the same over
UDP in real time."""
from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from .bringup import GuidedScene, VirtualUnit
from ..physics import VirtualStrainSensor
from .pty_device import PtyDevice
from .rdt_server import RdtServer


@dataclass
class ReferenceRun:
    t_ft: np.ndarray
    counts: np.ndarray
    """(N, 4) tared counts at 80 SPS."""
    true_force: np.ndarray
    """(N, 3) the force at each frame's time."""
    t_ref: np.ndarray
    """Reference times in the fingertip's clock plus ``delay_s`` (arrival-smoothed)."""
    f_ref: np.ndarray
    delay_s: float
    scene: GuidedScene


def random_presses(scene: GuidedScene, duration_s: float, rng: np.random.Generator,
                   start_s: float = 1.0, max_n: float = 4.0,
                   height_mm: float | None = None) -> None:
    """Presses of random direction, size, speed and height (0-5 mm, or ``height_mm``)
    until ``duration_s``."""
    t = start_s
    while True:
        ramp, hold = rng.uniform(0.6, 1.5), rng.uniform(0.3, 1.5)
        if t + 2 * ramp + hold > duration_s - 0.5:
            return
        h = rng.uniform(0.0, 5.0)
        end = scene.press(t, rng.uniform(0, 360), rng.uniform(0.5, max_n), ramp, hold,
                          h if height_mm is None else height_mm)
        t = end + rng.uniform(0.3, 1.0)


def simulate_reference_run(seed: int = 0, duration_s: float = 120.0, *, delay_s: float = 0.037,
                           rate_hz: float = 1000.0, loss: float = 0.01, jitter_s: float = 5e-4,
                           noise_n: float = 0.01, rate_sps: int = 80) -> ReferenceRun:
    rng = np.random.default_rng([seed, 1717])
    scene = GuidedScene()
    random_presses(scene, duration_s, rng)
    sensor = VirtualStrainSensor(seed, rate_sps=rate_sps)
    t_ft = np.arange(0.0, duration_s, 1.0 / rate_sps)
    fs = scene.forces(t_ft)
    counts = sensor.counts_batch(fs.xy, fs.height_mm, t_ft, fs.z).astype(float)
    counts -= counts[t_ft < 0.8].mean(axis=0)  # tared at rest, as `fingertip tare` does
    true = np.column_stack([fs.xy, fs.z])
    # The reference: samples at its own rate, reporting the force delay_s late; 1 % lost;
    # arrival jitter that the RDT client's smoothing removes (modelled here as what is left).
    n = int(duration_s * rate_hz)
    ts = np.arange(n) / rate_hz
    keep = rng.random(n) >= loss
    fr = scene.forces(ts[keep])
    f_ref = np.column_stack([fr.xy, fr.z]) + rng.normal(0, noise_n, (int(keep.sum()), 3))
    arrival = ts[keep] + delay_s + rng.exponential(jitter_s, int(keep.sum()))
    from ...reference.rdt import smooth_arrivals

    t_ref = smooth_arrivals(np.flatnonzero(keep).astype(float), arrival)
    return ReferenceRun(t_ft, counts, true, t_ref, f_ref, delay_s, scene)


@contextlib.contextmanager
def virtual_rdt_rig(seed: int, duration_s: float, *, delay_s: float = 0.037,
                    loss: float = 0.01) -> Iterator[tuple[str, str, Callable[[], None]]]:
    """A virtual unit behind a pty, random presses, and an RDT reference simulator on
    127.0.0.1 fed by the unit's true forces (its own delay, noise and packet loss), in real
    time: yields the pty's port, the simulator's ``HOST:PORT`` and ``begin()``, which
    starts the presses (call it after the tare: nothing may touch the unit then)."""
    unit = VirtualUnit(seed)
    with PtyDevice(unit.firmware) as dev:
        def force_at(host_t: float) -> np.ndarray:
            f = unit.scene.forces(np.array([dev.device_time_s(host_t)]))
            return np.array([f.xy[0, 0], f.xy[0, 1], f.z[0]])

        def begin() -> None:  # presses start after the tare, from the device's now
            random_presses(unit.scene, unit.now_s + duration_s, np.random.default_rng(seed),
                           start_s=unit.now_s + 1.0)

        with RdtServer(force_at, delay_s=delay_s, loss=loss, seed=seed) as server:
            yield dev.port, f"127.0.0.1:{server.port}", begin
