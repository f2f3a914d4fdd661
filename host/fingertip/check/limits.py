"""What the parts should do: the HX711 datasheet and the paper's build (one 120 ohm quarter
bridge per channel at gain 128, 4.3 V excitation), and the limits the checks apply.

The chip figures are the datasheet's (input-referred noise 50 nV rms at 10 SPS, 90 nV rms at
80 SPS, gain 128, full scale +-0.5 AVDD / gain); the virtual fingertip's parameter file uses
the same numbers, so its units pass by construction only if the simulator keeps to them.
"""
from __future__ import annotations

COUNTS_FULL_SCALE = 1 << 23
AVDD_V = 4.3
GAIN = 128
NOISE_NV_RMS = {10: 50.0, 80: 90.0}


def counts_per_volt(gain: int = GAIN, avdd_v: float = AVDD_V) -> float:
    return COUNTS_FULL_SCALE / (0.5 * avdd_v / gain)


def expected_noise_counts(rate_sps: int, gain: int = GAIN) -> float:
    """Input noise in counts rms the datasheet promises at this rate and gain (the HX711's
    noise is input-referred: at gain 64 half as many counts per volt)."""
    return NOISE_NV_RMS[rate_sps] * 1e-9 * counts_per_volt(gain)


# Rate: the chip's oscillator is +-10 % or so (datasheet: typ 10/80 SPS with the internal
# oscillator); beyond that the RATE pin or XI is wrong.
RATE_WARN_REL = 0.10
RATE_FAIL_REL = 0.25
TIMEOUT_WARN = 0.01
"""Fraction of readings a chip may miss before a warning (1 %); all missed: a failure."""
TIMEOUT_FAIL = 0.5

NOISE_WARN_X = 2.5
"""Noise at rest, times the datasheet figure: a warning above 2.5x, a failure above 5x."""
NOISE_FAIL_X = 5.0
MAINS_WARN_X = 3.0
"""50/60 Hz pick-up (its alias at the chip's rate), times the noise rms: a warning."""

BALANCE_WARN = 0.5
"""Untared offset at rest as a fraction of full scale: a warning above 50 % (less than half
the range left for force; a quarter bridge from 0.1 % resistors with its lead resistance
sits within about +-35 %), a failure at saturation."""
BALANCE_FAIL = 0.90

DRIFT_WARN_X = 10.0
"""Drift at rest in counts per minute, times the noise rms."""
DRIFT_SIGNIFICANCE = 4.0
"""A slope is only called drift when it is this many standard errors from zero (2.5 s of
white noise alone gives slopes of hundreds of counts per minute)."""
RETURN_WARN = 0.15
"""Level after the presses, off the level before, as a fraction of a press's response."""

SENSITIVITY_FAIL = 0.4
"""A channel's press response against the median of its pair and the others: below 40 %,
the gauge is loose (or the wrong gauge, or a wrong resistor)."""
SENSITIVITY_WARN = 0.65
PRESS_MIN_X = 20.0
"""A press must move the strongest channel by this many noise rms to count as a press."""

# Piezo: levels in dBFS of the sound card.
AUDIO_RATES = (44100, 48000, 96000)
AUDIO_DC_WARN = 0.05
AUDIO_FLOOR_MIN_DBFS = -85.0
"""Quieter than this at rest: nothing is connected (the card's own floor is about -90)."""
AUDIO_HUM_WARN_DBFS = -50.0
AUDIO_HUM_OVER_FLOOR_DB = 38.0
"""Hum this far above the broadband floor is a ground loop (normal pick-up: about 30 dB)."""
AUDIO_CLIP_FAIL = 1e-3
"""Fraction of samples at full scale while tapping."""
AUDIO_TAP_SNR_DB = 20.0
"""A tap must stand this far above the rest level (above 1 kHz) to be heard: the peak of
1.5 s of white noise alone is about 13 dB over its rms."""
AUDIO_DELAY_WARN_S = 0.05
"""Between a tap in force and in sound (one strain period is 12.5 ms at 80 SPS)."""
