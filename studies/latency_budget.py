"""The latency budget of a force frame, end to end on the real firmware in simavr.

Stages, per frame:

1. HX711 conversion ready (chip 0's DOUT falls) -> the firmware starts reading (first SCK
   rise): simulated AVR cycles (the harness's ``latency`` stats);
2. ... -> the frame's last bit leaves the UART pin (read, encode, the UART at its rate):
   simulated cycles;
3. the last byte read by the host (the transport's reader thread, the frame's
   ``arrival_time``) -> the decoded frame handed to the user's callback: wall clock on this
   machine (shared and noisy), through the real :class:`fingertip.Fingertip` on the pty.

The wire itself (stage 2) depends on the rate: 10 bits a byte; at 16 MHz with U2X the
Arduino core sets UBRR = (F_CPU / 4 / baud - 1) / 2, rounded down, and the actual rate is
F_CPU / (8 (UBRR + 1)) (:func:`uart_rate`). Between the pin and the host's read a real Uno
adds its USB bridge (the ATmega16U2 batches bytes into USB packets): not simulated here (the
harness's pty delivers each byte as it is written), so stage 2 + 3 is a lower bound.
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fingertip.sim.device.simavr import REPO, FirmwareSim, open_fingertip

F_CPU = 16_000_000
RATES = (115200, 500000, 1000000)


def uart_rate(baud: int, f_cpu: int = F_CPU) -> tuple[float, float]:
    """(actual rate, relative error) of the Arduino core's HardwareSerial at ``baud``: U2X
    on, UBRR = (f_cpu / 4 / baud - 1) // 2 (57600 at 16 MHz, U2X off, is the core's one
    exception)."""
    if baud <= 0:
        raise ValueError("baud must be > 0")
    if f_cpu == 16_000_000 and baud == 57600:
        ubrr = (f_cpu // 8 // baud - 1) // 2
        actual = f_cpu / (16 * (ubrr + 1))
    else:
        ubrr = (f_cpu // 4 // baud - 1) // 2
        actual = f_cpu / (8 * (ubrr + 1))
    return actual, actual / baud - 1


def elf_for(channels: int, baud: int) -> Path:
    """The firmware built for ``channels`` at ``baud`` (``make -C firmware bauds`` builds
    each rate into firmware/build/b<baud>/)."""
    path = REPO / "firmware" / "build" / f"b{baud}" / f"fw{channels}" / "fingertip.elf"
    if not path.exists():
        raise FileNotFoundError(f"no firmware at {path}: run `make -C firmware bauds`")
    return path


@dataclass
class Budget:
    channels: int
    baud: int
    frames: int
    ready_to_read_us: np.ndarray
    ready_to_sent_us: np.ndarray
    host_us: np.ndarray
    """Arrival (last byte read) -> user callback, wall clock."""
    byte_us: float
    extra: dict = field(default_factory=dict)

    def row(self) -> dict[str, float]:
        actual, err = uart_rate(self.baud)
        p = np.percentile
        total = self.ready_to_sent_us + np.percentile(self.host_us, 50)
        return {
            "channels": self.channels, "baud": self.baud, "actual_baud": round(actual, 1),
            "baud_error_pct": round(100 * err, 3), "frames": self.frames,
            "ready_to_read_p50_us": round(float(p(self.ready_to_read_us, 50)), 2),
            "ready_to_read_p99_us": round(float(p(self.ready_to_read_us, 99)), 2),
            "ready_to_sent_p50_us": round(float(p(self.ready_to_sent_us, 50)), 2),
            "ready_to_sent_p99_us": round(float(p(self.ready_to_sent_us, 99)), 2),
            "host_p50_us": round(float(p(self.host_us, 50)), 2),
            "host_p99_us": round(float(p(self.host_us, 99)), 2),
            "total_p99_ms": round(float(p(self.ready_to_sent_us, 99)
                                        + p(self.host_us, 99)) / 1e3, 4),
            "total_p50_ms": round(float(p(total, 50)) / 1e3, 4),
        }


def measure(channels: int, baud: int, sim_seconds: float = 10.0) -> Budget:
    """Stream ``sim_seconds`` of simulated time from the firmware built for ``baud`` and
    collect every stage of every frame."""
    host: list[float] = []
    lock = threading.Lock()

    def on_frame(frame) -> None:
        now = time.monotonic()
        with lock:
            host.append(now - frame.arrival_time)

    with FirmwareSim(channels, elf_for(channels, baud)) as sim:
        with open_fingertip(sim, baudrate=baud, queue_size=100_000) as ft:
            ft.add_callback(on_frame)
            ft.start()
            sim.until(sim.time_us() + 0.5e6, timeout=600)
            sim.stats_reset()
            with lock:
                host.clear()
            t0 = sim.time_us()
            sim.until(t0 + sim_seconds * 1e6, timeout=600)
            time.sleep(0.3)
            st = sim.stats()
    lat = st["latency"]
    return Budget(channels, baud, int(lat["frames"]),
                  np.asarray(lat["ready_to_read_ns"], float) / 1e3,
                  np.asarray(lat["ready_to_sent_ns"], float) / 1e3,
                  np.asarray(host, float) * 1e6, float(lat["byte_us"]),
                  {"overwritten": lat["overwritten"], "speed": st["speed"]["ratio"]})


def table(rows: list[dict[str, float]]) -> str:
    lines = ["| channels | baud (actual, error) | frames | conversion -> read p50/p99 | "
             "conversion -> last bit sent p50/p99 | host read -> callback p50/p99 | "
             "total p99 |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(
            f"| {r['channels']} | {r['baud']} ({r['actual_baud']:g}, {r['baud_error_pct']:+g} %)"
            f" | {r['frames']} | {r['ready_to_read_p50_us']:.1f} / {r['ready_to_read_p99_us']:.1f}"
            f" us | {r['ready_to_sent_p50_us']:.0f} / {r['ready_to_sent_p99_us']:.0f} us | "
            f"{r['host_p50_us']:.0f} / {r['host_p99_us']:.0f} us | {r['total_p99_ms']:.3f} ms |")
    return "\n".join(lines) + "\n"
