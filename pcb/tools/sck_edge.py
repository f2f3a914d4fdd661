#!/usr/bin/python3
"""The SCK edge of the hand shield: one Uno pin driving 16 HX711 clock inputs.

    python3 pcb/tools/sck_edge.py [pcb/hand/hand.kicad_pcb]

Lumped RC: the AVR pin's output resistance against the pin, the 16 inputs and the routed
track (its length read from the board). The line is short against the edge (checked:
one-way delay < rise time / 6), so no transmission-line model is needed. Compared with the
HX711's timing: SCK high and low at least T3 = T4 = 0.2 us (datasheet, "Serial interface
timing"); the firmware's SCK pulse is 0.69 us high (11 cycles, firmware/sim measurements).
"""
from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from sexpr import find, find_all, parse  # noqa: E402

# ATmega328P at 5 V: VOH = 4.2 V at 20 mA (datasheet, I/O pin output high voltage), so about
# 0.8 V / 20 mA = 40 ohm at that current and ~25 ohm for small ones: take 40 (the slower).
R_DRIVER_OHM = 40.0
C_AVR_PIN_PF = 10.0          # the Uno's own pin, pad and the ICSP header trace on D12
# The HX711 datasheet gives no input capacitance: 10 pF is above what CMOS logic inputs with
# ESD protection show (3-5 pF); the result has a wide margin, so the guess is not critical.
C_HX711_INPUT_PF = 10.0
INPUTS = 16
T_SCK_MIN_US = 0.2           # HX711 T3 (SCK high) and T4 (SCK low), minimum
T_SCK_FIRMWARE_US = 0.69     # the firmware's SCK-high pulse (11 cycles at 16 MHz)
EPS_R = 4.5                  # FR-4
H_MM = 1.6                   # to the pour on the other side
T_MM = 0.035                 # 1 oz copper
C0 = 299.792458              # mm/ns


@dataclass
class SckEdge:
    track_mm: float
    vias: int
    c_track_pf: float
    c_total_pf: float
    rise_ns: float
    delay_ns: float

    @property
    def lumped(self) -> bool:
        return self.delay_ns < self.rise_ns / 6

    @property
    def margin(self) -> float:
        """How many rise times fit in the HX711's minimum SCK high time."""
        return T_SCK_MIN_US * 1e3 / self.rise_ns


def microstrip(width_mm: float) -> tuple[float, float]:
    """(pF per mm, effective permittivity) of a track over a plane (IPC-2141 /
    Hammerstad). Doubled for the same-layer pour beside the track (coplanar ground, 0.25 mm
    gap): an upper bound that keeps the estimate on the slow side."""
    w, h, t = width_mm, H_MM, T_MM
    eps_eff = (EPS_R + 1) / 2 + (EPS_R - 1) / 2 / math.sqrt(1 + 12 * h / w)
    z0 = 87.0 / math.sqrt(EPS_R + 1.41) * math.log(5.98 * h / (0.8 * w + t))
    c_per_mm = math.sqrt(eps_eff) / (C0 * z0) * 1e3   # ns/mm / ohm = nF/mm -> pF/mm
    return 2.0 * c_per_mm, eps_eff


def sck_track(board: Path, net: str = "SCK") -> tuple[float, int, float]:
    """Total length (mm) and via count of the net's copper, and the track width (mm)."""
    tree = parse(board.read_text(encoding="utf-8"))
    codes = {str(n[1]) for n in find_all(tree, "net") if str(n[2]).lstrip("/") == net}
    length, width, vias = 0.0, 0.2, 0
    for seg in find_all(tree, "segment"):
        if str(find(seg, "net")[1]) in codes:
            (x0, y0), (x1, y1) = (map(float, find(seg, k)[1:3]) for k in ("start", "end"))
            length += math.hypot(x1 - x0, y1 - y0)
            width = float(find(seg, "width")[1])
    for v in find_all(tree, "via"):
        if str(find(v, "net")[1]) in codes:
            vias += 1
    return length, vias, width


def sck_edge(board: Path) -> SckEdge:
    length, vias, width = sck_track(board)
    c_mm, eps_eff = microstrip(width)
    c_track = c_mm * length + 0.5 * vias          # about 0.5 pF per via through 1.6 mm
    c_total = C_AVR_PIN_PF + INPUTS * C_HX711_INPUT_PF + c_track
    rise = 2.2 * R_DRIVER_OHM * c_total * 1e-3    # 10-90 %, ns (ohm * pF = ps)
    delay = length * math.sqrt(eps_eff) / C0      # the whole tree as one run: an upper bound
    return SckEdge(length, vias, c_track, c_total, rise, delay)


def main() -> int:
    board = Path(sys.argv[1]) if len(sys.argv) > 1 else HERE.parent / "hand" / "hand.kicad_pcb"
    e = sck_edge(board)
    print(f"SCK copper {e.track_mm:.0f} mm, {e.vias} vias: {e.c_track_pf:.0f} pF; with the "
          f"pin and {INPUTS} x {C_HX711_INPUT_PF:g} pF inputs {e.c_total_pf:.0f} pF")
    print(f"10-90 % edge 2.2 x {R_DRIVER_OHM:g} ohm x C = {e.rise_ns:.1f} ns; HX711 minimum "
          f"SCK high/low {T_SCK_MIN_US * 1e3:.0f} ns ({e.margin:.0f} edges); firmware pulse "
          f"{T_SCK_FIRMWARE_US * 1e3:.0f} ns")
    verdict = ("lumped, no termination needed" if e.lumped
               else "a transmission line: terminate")
    print(f"one-way delay of the whole copper {e.delay_ns:.2f} ns "
          f"{'<' if e.lumped else '>='} rise / 6: {verdict}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
