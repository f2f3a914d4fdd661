"""Class folders of band-limited noise at random gains: easy, fast material datasets."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import soundfile as sf
from scipy.signal import butter, sosfilt


def write_band_noise(root: Path, bands: dict[str, tuple[float, float]], per_class: int = 6,
                     rate: int = 8000, seconds: float = 1.0, seed: int = 0) -> Path:
    """One sub-folder per class of ``bands`` (label: (low Hz, high Hz)), ``per_class``
    16-bit WAV recordings each: noise in that band over a faint white floor, each at its own
    gain (a tenth of full scale to a third)."""
    rng = np.random.default_rng(seed)
    n = int(seconds * rate)
    for label, (lo, hi) in bands.items():
        sos = butter(4, [lo / (rate / 2), hi / (rate / 2)], "bandpass", output="sos")
        (root / label).mkdir(parents=True, exist_ok=True)
        for i in range(per_class):
            x = sosfilt(sos, rng.standard_normal(n)) + 0.05 * rng.standard_normal(n)
            x *= 0.3 * 10 ** rng.uniform(-1, 0) / np.abs(x).max()
            sf.write(root / label / f"{i}.wav", x, rate, subtype="PCM_16")
    return root
