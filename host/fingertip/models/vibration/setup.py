"""The material trainer's features and windows, adapted to the data (and why).

:func:`choose_setup` reads the recordings' rates and lengths and decides the band range,
the first and the longest window and the prediction step, with the reason for each (a
folder of 1 s slides at 2.2 kHz and one of 0.3 s knocks at 44.1 kHz both train without
options).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from .classify import Dataset, WindowSpec
from .features import FeatureConfig

LONGEST_S = 2.0
"""The longest window: beyond it, windows slide and their answers are averaged."""
FIRST_S = 0.25
STEP_S = 0.1


@dataclass
class Setup:
    """Features and windows chosen for a dataset, and why."""

    cfg: FeatureConfig
    first_s: float
    longest_s: float
    step_s: float
    reasons: dict[str, str] = field(default_factory=dict)

    def frames(self, seconds: float) -> int:
        """Frames of a window whose audio spans ``seconds`` (at least 2)."""
        return max(2, int((seconds - self.cfg.win_s) / self.cfg.hop_s + 1e-6) + 1)

    def spec(self, stats: Sequence[str]) -> WindowSpec:
        return WindowSpec(self.frames(self.longest_s), self.step_s, "growing",
                          self.frames(self.first_s), tuple(stats))

    def to_dict(self) -> dict:
        return {"features": self.cfg.to_dict(), "first_window_s": self.first_s,
                "longest_window_s": self.longest_s, "step_s": self.step_s,
                "why": self.reasons}


def choose_setup(ds: Dataset, features: FeatureConfig | None = None,
                 max_hz: float | None = None, window_s: float | None = None,
                 step_s: float | None = None) -> Setup:
    """Bands, windows and step for the recordings of ``ds`` (arguments that are given win).

    - bands: top at 0.9 x the lowest rate's Nyquist (at most 7.2 kHz); bottom six octaves
      below it, between 30 and 100 Hz (low rates keep their low frequencies, where slow
      textures live; high rates stay above mains hum);
    - longest window: the median recording's length, at most 2 s (a slide's spectrum is
      then estimated from all of it; longer recordings average 2 s windows);
    - first window: 0.25 s, or half the shortest recording when that is shorter (a 0.3 s
      knock gets a first answer at 0.15 s); at least 3 frames;
    - step: 0.1 s (10 Hz answers), or a tenth of the median length for short recordings.
    """
    base = features or FeatureConfig()
    cfg = base.for_rates(ds.rates, max_hz)
    reasons = {"f_hi": f"{cfg.f_hi:g} Hz: 0.9 x the Nyquist frequency of the lowest rate "
                       f"({min(ds.rates):g} Hz), at most {base.top_for_rate(1e9):g} Hz"}
    if features is None or features.f_lo == FeatureConfig().f_lo:
        f_lo = float(min(100.0, max(30.0, cfg.f_hi / 72)))
        cfg = replace(cfg, f_lo=round(f_lo, 1))
        reasons["f_lo"] = (f"{cfg.f_lo:g} Hz: six octaves below the top, kept within "
                           "30-100 Hz (above mains hum when the band allows)")
    durations = np.array([it.rec.duration for it in ds.items])
    med, shortest = float(np.median(durations)), float(durations.min())
    min_span = cfg.win_s + 2 * cfg.hop_s
    if window_s is None:
        longest = min(LONGEST_S, med)
        reasons["longest_window"] = (f"{longest:.3g} s: the median recording lasts "
                                     f"{med:.3g} s (windows never exceed {LONGEST_S:g} s; "
                                     "longer recordings average sliding windows)")
    else:
        longest = float(window_s)
        reasons["longest_window"] = f"{longest:.3g} s: given"
    longest = max(longest, min_span)
    first = min(FIRST_S, max(min_span, shortest / 2), longest)
    reasons["first_window"] = (f"{first:.3g} s: the first answer ({FIRST_S:g} s, or half of "
                               f"the shortest recording, {shortest:.3g} s)")
    if step_s is None:
        step = min(STEP_S, max(cfg.hop_s, med / 10))
        reasons["step"] = f"{step:.3g} s between answers ({STEP_S:g} s, or a tenth of the " \
                          "median recording for short ones)"
    else:
        step = float(step_s)
        reasons["step"] = f"{step:.3g} s: given"
    return Setup(cfg, round(first, 4), round(longest, 4), round(step, 4), reasons)
