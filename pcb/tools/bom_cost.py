#!/usr/bin/python3
"""Cost of a board from its BOM (kicad-cli CSV with MPN and Qty) and pcb/prices.csv.

    python3 pcb/tools/bom_cost.py BOM.csv --pcb PCB_100x100_2L_5PCS [--boards 5]

Per board: every BOM line's quantity x its unit price, plus one shunt per 2x3 RATE header,
plus the bare board's share of a batch. Fails (exit 2) on an MPN without a price.
"""
from __future__ import annotations

import argparse
import csv
import sys
from dataclasses import dataclass, field
from pathlib import Path

PRICES = Path(__file__).resolve().parents[1] / "prices.csv"
# parts the BOM implies but does not list: the RATE jumper's shunt
EXTRA = {"61300621121": [("60900213421", 1)]}


@dataclass
class Cost:
    parts_usd: float
    pcb_usd: float
    lines: list[tuple[str, int, float]] = field(default_factory=list)

    @property
    def total_usd(self) -> float:
        return self.parts_usd + self.pcb_usd


def prices(path: Path = PRICES) -> dict[str, float]:
    rows = [ln for ln in path.read_text(encoding="utf-8").splitlines()
            if ln.strip() and not ln.startswith("#")]
    return {r["MPN"]: float(r["unit_usd"]) for r in csv.DictReader(rows)}


def board_cost(bom_csv: Path, pcb_item: str, boards: int = 5,
               price: dict[str, float] | None = None) -> Cost:
    """Cost of one board when ``boards`` are made (the bare boards come as one batch)."""
    price = price if price is not None else prices()
    lines: list[tuple[str, int, float]] = []
    for r in csv.DictReader(bom_csv.open(encoding="utf-8")):
        qty = int(r["Qty"])
        items = [(r["MPN"], qty)] + [(m, k * qty) for m, k in EXTRA.get(r["MPN"], [])]
        for mpn, q in items:
            if mpn not in price:
                raise KeyError(f"no price for {mpn} in {PRICES.name}")
            lines.append((mpn, q, q * price[mpn]))
    if pcb_item not in price:
        raise KeyError(f"no price for {pcb_item} in {PRICES.name}")
    return Cost(sum(c for _, _, c in lines), price[pcb_item] / boards, lines)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("bom", type=Path)
    ap.add_argument("--pcb", required=True, help="the bare board's line in prices.csv")
    ap.add_argument("--boards", type=int, default=5)
    a = ap.parse_args()
    try:
        c = board_cost(a.bom, a.pcb, a.boards)
    except (KeyError, OSError, ValueError) as e:
        print(f"bom_cost: {e}", file=sys.stderr)
        return 2
    for mpn, q, usd in sorted(c.lines, key=lambda x: -x[2]):
        print(f"{q:4d} x {mpn:<22} {usd:8.2f}")
    print(f"parts {c.parts_usd:.2f} + bare board {c.pcb_usd:.2f} = {c.total_usd:.2f} USD per "
          f"board (of {a.boards})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
