"""The hand: 16 channels on one Uno (pcb/hand) split into four fingertips.

Frame rate per fingertip with the 16-channel firmware in simavr through Fingertip and
Hand.split (device time: simavr counts AVR cycles, so the figure does not depend on this
machine's load); the hand board's DRC errors (kicad-cli 9, schematic parity); its cost per
board at a batch of five, from the BOM and pcb/prices.csv (prices entered by hand, not quotes).
"""
from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from fingertip.device import Hand
from fingertip.sim.device.simavr import FirmwareSim, firmware_elf, open_fingertip

ROOT = Path(__file__).resolve().parents[2]
HAND = ROOT / "pcb" / "hand"
SIM_SECONDS = 10.0
GROUPS = {f"f{k}": tuple(range(4 * k, 4 * k + 4)) for k in range(4)}


def frame_rate() -> tuple[float, int]:
    """Frames per simulated second of the slowest finger, and frames lost."""
    with FirmwareSim(16, firmware_elf(16)) as sim:
        for ch in range(16):
            sim.set(ch, 1000 + ch)
        with open_fingertip(sim, queue_size=100_000) as ft:
            hand = Hand.split(ft, GROUPS)
            got: dict[str, list[int]] = {f: [] for f in GROUPS}
            hand.add_callback(lambda f, fr: got[f].append(fr.device_time_us))
            ft.start()
            t0 = sim.time_us()
            sim.until(t0 + SIM_SECONDS * 1e6, timeout=900)
            time.sleep(0.5)
            lost = ft.stats.frames_lost
    rates = [(len(t) - 1) / ((t[-1] - t[0]) / 1e6) for t in got.values()]
    return min(rates), lost


def drc_errors() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "drc.json"
        subprocess.run(["kicad-cli", "pcb", "drc", "--format", "json", "--schematic-parity",
                        "-o", str(out), str(HAND / "hand.kicad_pcb")], check=True,
                       capture_output=True, timeout=900)
        data = json.loads(out.read_text())
    return sum(1 for k in ("violations", "unconnected_items", "schematic_parity")
               for v in data.get(k, []) if v["severity"] == "error")


def cost_usd() -> float:
    sys.path.insert(0, str(ROOT / "pcb" / "tools"))
    from bom_cost import board_cost

    with tempfile.TemporaryDirectory() as tmp:
        bom = Path(tmp) / "hand-bom.csv"
        subprocess.run(["kicad-cli", "sch", "export", "bom", "-o", str(bom), "--fields",
                        "Reference,Value,Footprint,Manufacturer,MPN,${QUANTITY}", "--labels",
                        "Reference,Value,Footprint,Manufacturer,MPN,Qty", "--group-by",
                        "Value,Footprint,MPN", str(HAND / "hand.kicad_sch")], check=True,
                       capture_output=True, timeout=300)
        return board_cost(bom, "PCB_100x100_2L_5PCS", boards=5).total_usd


def run() -> dict[str, float]:
    rate, lost = frame_rate()
    return {"hand_frame_rate_hz": round(rate, 3), "hand_frames_lost": lost,
            "hand_board_drc_errors": drc_errors(),
            "hand_board_cost_usd": round(cost_usd(), 2)}


DESCRIPTION = {
    "hand_frame_rate_hz": ("frames per simulated second of each fingertip (the slowest), "
                           "16-channel firmware in simavr split 4x4 by Hand.split, 80 SPS",
                           (">=", 79.99)),
    "hand_frames_lost": ("frames lost (sequence gaps) in that run", ("<=", 0)),
    "hand_board_drc_errors": ("pcb/hand: kicad-cli 9 DRC errors incl. unconnected items and "
                              "schematic parity", ("<=", 0)),
    "hand_board_cost_usd": ("pcb/hand: parts + bare board per board, batch of 5 (BOM x "
                            "pcb/prices.csv, hand-entered prices; Uno, cables, adapter "
                            "excluded)", None),
}
