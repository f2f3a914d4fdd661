"""The firmware's pin map (firmware/src/pins.h), read by the board generators: one source.

    channel n -> Arduino pin name of its DOUT ("D2", "A0", ...); SCK and RATE pin names.
"""
from __future__ import annotations

import re
from pathlib import Path

PINS_H = Path(__file__).resolve().parents[2] / "firmware" / "src" / "pins.h"


def arduino_name(pin: int) -> str:
    """Uno pin number -> header name: 14..19 are A0..A5."""
    return f"A{pin - 14}" if pin >= 14 else f"D{pin}"


def firmware_pins(path: Path = PINS_H) -> dict:
    """{"SCK": "D12", "RATE": "D13", "DOUT": ["D2", ..., "D11"]} from the #defines."""
    text = path.read_text(encoding="utf-8")
    macro = {m.group(1): m.group(2) for m in re.finditer(r"#define (FT_\w+) (.+)", text)}
    douts = [int(v) for v in re.findall(r"\d+", macro["FT_DOUT_ARDUINO_PINS"])]
    return {"SCK": arduino_name(int(macro["FT_SCK_ARDUINO_PIN"])),
            "RATE": arduino_name(int(macro["FT_RATE_ARDUINO_PIN"])),
            "DOUT": [arduino_name(p) for p in douts]}
