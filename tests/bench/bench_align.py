"""Force and audio on one host clock (the alignment test's measurement, as a figure)."""
from __future__ import annotations

from tests.firmware.in_loop.alignment import measure


def run() -> dict[str, float]:
    results = [measure(100.0, -100.0, seconds=20.0), measure(-100.0, 100.0, seconds=20.0)]
    return {
        "align_error_ms": round(max(r.align_error_ms for r in results), 3),
        "align_force_map_error_ms": round(max(r.force_error_ms for r in results), 3),
        "align_audio_map_error_ms": round(max(r.audio_error_ms for r in results), 3),
    }


DESCRIPTION = {
    "align_error_ms": ("worst gap between the force and audio maps for one instant: firmware "
                       "in simavr at +-100 ppm, sound card at -+100 ppm and a 0.32 s offset",
                       ("<", 1.0)),
    "align_force_map_error_ms": ("worst force-map error against the simulator's pacing",
                                 ("<", 1.0)),
    "align_audio_map_error_ms": ("worst audio-map error against the card's true clock",
                                 ("<", 1.0)),
}
