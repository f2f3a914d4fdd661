"""Force and audio on one host clock: the firmware in simavr paced with a clock error, and a
sound card with its own clock error and a known offset, each mapped by its own estimator.

Ground truth:
- Device: simavr paces simulated time to the host clock with ``throttle`` F (simulated seconds
  per host second), so device time ``t`` is due at host time ``w0 + t / F``; F = 1 + 100 ppm
  is a device crystal 100 ppm fast. The harness's ``time`` reply gives ``due_s``, the host
  monotonic time its pacing assigns to the current simulated instant, so ``w0`` is exact
  (to a microsecond) whatever the reply's travel time. simavr itself runs up to a millisecond
  ahead of that line and behind it when the machine is busy: to the estimator those are frames
  sent early or late, as a real device's USB transfers and a busy host make them.
- Audio: a simulated sound card whose frame ``k`` was digitised at ``a0 + k / (fs (1 + e))``
  (``e``: its crystal error, ``a0``: the injected offset); it delivers blocks as a real card
  does, after a fixed latency plus scheduling jitter, to the same estimator the live capture
  uses (fingertip.clockfit.FrameClock with its reported latency taken out).

The error is how far apart the two maps put one physical instant, and how far each is from
the truth.
"""
from __future__ import annotations

import inspect
import random
import statistics
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from fingertip.clockfit import LATE_S, FrameClock
from fingertip.device.timesync import ClockSync
from fingertip.sim.device.simavr import FirmwareSim, firmware_elf, open_fingertip

FS = 44_100
BLOCK = 441
LATENCY = 0.008
_MAP = inspect.signature(ClockSync).parameters
WINDOW_S: float = _MAP["window_s"].default
"""The device map's history (ClockSync's default window)."""
BIN_S: float = _MAP["bin_s"].default
MIN_ON_TIME_S: float = _MAP["min_span_s"].default
"""How much of that window must hold frames that came on time (less than the map's LATE_S
late) for the map to know the line: the history it needs to read a rate."""


@dataclass
class AlignResult:
    align_error_ms: float       # worst |force map - audio map| for the same instant
    force_error_ms: float       # worst |force map - truth|
    audio_error_ms: float       # worst |audio map - truth|
    frames: int
    trace: list[tuple[int, float, float]] = field(default_factory=list, repr=False)
    """Per frame: device time (us), arrival - truth (ms), force map - truth (ms)."""

    @property
    def on_time_s(self) -> float:
        """Seconds of the map's window (the last WINDOW_S of frames) in BIN_S bins with a
        frame less than LATE_S late. None there: simavr ran behind its pacing line for the
        whole window (a starved host), and no map can find a line it was never shown."""
        last = int(self.trace[-1][0] // (BIN_S * 1e6))
        first = last - round(WINDOW_S / BIN_S) + 1
        bins = {int(d // (BIN_S * 1e6)) for d, late_ms, _ in self.trace
                if late_ms < LATE_S * 1e3}
        return sum(1 for b in bins if b >= first) * BIN_S

    def write_trace(self, path: Path) -> Path:
        """The frames as CSV, to replay a failed run through the clock map offline."""
        rows = ["device_time_us,arrival_minus_truth_ms,map_minus_truth_ms"]
        rows += [f"{d},{a:.4f},{m:.4f}" for d, a, m in self.trace]
        path.write_text("\n".join(rows) + "\n")
        return path


def _sound_card(stop: threading.Event, clock: FrameClock, a0: float, err: float,
                seed: int) -> None:
    rng = random.Random(seed)
    rate = FS * (1 + err)
    k = 0
    while not stop.is_set():
        k += BLOCK
        captured = a0 + k / rate  # when frame k-1 was digitised (end of the block)
        deliver = captured + LATENCY + rng.expovariate(1 / 0.0015)
        delay = deliver - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        clock.observe(k, time.monotonic() - LATENCY)


def measure(device_ppm: float, audio_ppm: float, seconds: float = 25.0,
            offset_s: float = 0.3217, seed: int = 1) -> AlignResult:
    F = 1 + device_ppm * 1e-6
    with FirmwareSim(4, firmware_elf(4), throttle=F) as sim:
        with open_fingertip(sim, queue_size=100_000) as ft:
            ft.start()
            a0 = time.monotonic() + offset_s
            audio = FrameClock(FS)
            stop = threading.Event()
            card = threading.Thread(target=_sound_card,
                                    args=(stop, audio, a0, audio_ppm * 1e-6, seed))
            card.start()
            w0s = []
            t_end = time.monotonic() + seconds + offset_s
            while time.monotonic() < t_end:
                r = sim.command("time")
                w0s.append(r["due_s"] - r["t_us"] * 1e-6 / F)
                time.sleep(0.25)
            stop.set()
            card.join()
            frames = ft.drain()
            # One anchor for the whole run (the pacing's), to a microsecond.
            assert max(w0s) - min(w0s) < 1e-5, (min(w0s), max(w0s))
            w0 = statistics.median(w0s)

            def due(t_us: float) -> float:
                """The host time simavr's pacing gives device time ``t_us``: the truth."""
                return w0 + t_us * 1e-6 / F

            # Instants over the last 5 s, where both estimators have a full history.
            rng = random.Random(seed)
            last = frames[-1].device_time_us
            worst_align = worst_force = worst_audio = 0.0
            for _ in range(200):
                t_dev = last - rng.uniform(0, 5e6)
                truth = due(t_dev)
                force_est = ft.clock.to_host(t_dev)
                k = (truth - a0) * FS * (1 + audio_ppm * 1e-6)
                audio_est = audio.to_host(k)
                worst_align = max(worst_align, abs(force_est - audio_est))
                worst_force = max(worst_force, abs(force_est - truth))
                worst_audio = max(worst_audio, abs(audio_est - truth))
    trace = [(f.device_time_us, (f.arrival_time - due(f.device_time_us)) * 1e3,
              (f.host_time - due(f.device_time_us)) * 1e3) for f in frames]
    return AlignResult(worst_align * 1e3, worst_force * 1e3, worst_audio * 1e3, len(frames),
                       trace)
