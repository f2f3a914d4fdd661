"""The piezo checks: pure functions of a sound-card recording taken while the nail was
tapped, and of the tap times seen in the strain channels."""
from __future__ import annotations

import math

import numpy as np

from . import limits as L
from .results import FAIL, PASS, SKIP, WARN
from .signals import Segment
from .signals import make_result as _r

MAINS = (50.0, 60.0)
HARMONICS = 5
HP_HZ = 1000.0
"""Taps and the broadband floor are measured above this (hum lives below it)."""
HP_SETTLE_S = 0.03


def dbfs(rms: float) -> float:
    return 20 * math.log10(max(rms, 1e-12))


def hum_rms(x: np.ndarray, fs: float) -> tuple[float, float]:
    """Rms of the mains hum (fundamental and harmonics, 50 or 60 Hz, whichever is larger)
    and that mains frequency."""
    n = len(x)
    if n < int(fs * 0.1):
        return 0.0, MAINS[0]
    win = np.hanning(n)
    spec = np.abs(np.fft.rfft((x - x.mean()) * win)) * 2 / win.sum()
    freqs = np.fft.rfftfreq(n, 1 / fs)
    best = (0.0, MAINS[0])
    for m in MAINS:
        p = 0.0
        for k in range(1, HARMONICS + 1):
            sel = np.abs(freqs - k * m) <= max(2.0, 1.5 * fs / n)
            if sel.any():
                p += float(np.max(spec[sel])) ** 2 / 2
        best = max(best, (math.sqrt(p), m))
    return best


def force_tap_times(seg: Segment, noise: np.ndarray, skip: set[int] = frozenset(),
                    threshold_x: float = 10.0, hold_s: float = 0.15) -> list[float]:
    """Onsets of taps in the strain channels: a jump between two frames of more than
    ``threshold_x`` noise rms (the level itself may not come back after a tap: hysteresis),
    one per ``hold_s``; the onset is put half-way between the two frames."""
    good = [ch for ch in range(seg.channels) if ch not in skip]
    if len(seg) < 3 or not good:
        return []
    d = np.diff(seg.counts[:, good], axis=0)
    d[~np.isfinite(d)] = 0.0
    z = np.sqrt(np.sum((d / np.maximum(noise[good], 1.0)) ** 2, axis=1))
    times: list[float] = []
    for k in np.flatnonzero(z > threshold_x):
        t = float(seg.times_s[k] + seg.times_s[k + 1]) / 2
        if not times or t - times[-1] > hold_s:
            times.append(t)
    return times


def highpass(x: np.ndarray, fs: float, corner_hz: float = HP_HZ) -> np.ndarray:
    """``x`` without what lies below ``corner_hz`` (the hum and its harmonics). Causal (a
    4th-order Butterworth): a filter that rings before a tap would put its onset early."""
    from scipy.signal import butter, sosfilt

    return sosfilt(butter(4, corner_hz, "highpass", fs=fs, output="sos"), x)


def sound_onsets(x: np.ndarray, fs: float, floor_rms: float, snr_db: float,
                 hold_s: float = 0.15) -> list[int]:
    thr = max(floor_rms * 10 ** (snr_db / 20), 1e-6)
    above = np.flatnonzero(np.abs(x) > thr)
    out: list[int] = []
    for i in above:
        if not out or i - out[-1] > hold_s * fs:
            out.append(int(i))
    return out


def check_piezo(audio: np.ndarray | None, fs: float, t0: float, force_taps: list[float],
                taps_asked: int, name: str = "") -> list:
    """Sound card rate, DC offset, level at rest, hum, clipping, level while tapping and the
    delay between a tap in force and in sound. ``t0``: time of the first audio sample in the
    clock of ``force_taps``."""
    if audio is None:
        return [_r("piezo", SKIP, "no sound card", "", fix="")]
    x = np.asarray(audio, dtype=np.float64).reshape(-1)
    if x.size == 0:
        return [_r("piezo", FAIL, "the sound card delivered no samples", "> 0 samples", None,
                   "", f"{name or 'the card'} recorded nothing: is it still plugged in, and "
                   "not taken by another program (arecord -l, pavucontrol)?")]
    # A card's first buffers are often zero-filled before its stream runs: digital silence
    # is not the piezo at rest, and it would dilute the hum and floor measured below.
    lead = int(np.argmax(x != 0.0)) if np.any(x != 0.0) else 0
    x = x[lead:]
    t0 = t0 + lead / fs
    out = []
    st = PASS if int(round(fs)) in L.AUDIO_RATES else WARN
    out.append(_r("sound card", st, f"{name} at {fs:.0f} Hz",
                  "/".join(str(r) for r in L.AUDIO_RATES), None, "",
                  "set the card to 44100 or 48000 Hz (pavucontrol or alsamixer)"))
    first_tap = (min(force_taps) - t0) if force_taps else None
    rest_end = int(fs * (first_tap - 0.05)) if first_tap and first_tap > 0.15 else int(0.2 * fs)
    rest = x[:max(rest_end, 16)]
    dc = float(rest.mean())
    out.append(_r("piezo DC offset", WARN if abs(dc) > L.AUDIO_DC_WARN else PASS,
                  f"{dc:+.4f} FS", f"|x| <= {L.AUDIO_DC_WARN}", None, "",
                  "the card's input has a DC offset: the preamp's output coupling capacitor "
                  "is missing or leaky"))
    floor = float(np.sqrt(np.mean((rest - dc) ** 2)))
    quiet = dbfs(floor) < L.AUDIO_FLOOR_MIN_DBFS
    out.append(_r("piezo level at rest", WARN if quiet else PASS,
                           f"{dbfs(floor):.0f} dBFS",
                  f">= {L.AUDIO_FLOOR_MIN_DBFS:g} dBFS", None, "",
                  "the card hears only itself: is the piezo's cable plugged into the "
                  "preamp and the preamp into the card's microphone input?", dbfs=dbfs(floor)))
    # Hum and broadband floor over the same samples, so that their ratio does not depend on
    # the span. The high-pass filter starts from rest while the hum is already there: skip
    # its start-up.
    settle = min(int(HP_SETTLE_S * fs), len(rest) // 2)
    h, mains = hum_rms(rest[settle:], fs)
    hd = dbfs(h)
    # Broadband floor above the hum, scaled to the whole band (white noise).
    hp = highpass(x, fs)
    band = fs / 2
    hp_rest = hp[settle:len(rest)]
    broad = float(np.sqrt(np.mean(hp_rest ** 2) * band / (band - HP_HZ)))
    over = hd - dbfs(broad)
    # A preamp with too much gain raises hum and floor alike (a level warning); a ground
    # loop raises the hum far above the floor (a failure).
    st = FAIL if over > L.AUDIO_HUM_OVER_FLOOR_DB and hd > L.AUDIO_HUM_WARN_DBFS else \
        WARN if hd > L.AUDIO_HUM_WARN_DBFS else PASS
    out.append(_r("piezo hum", st, f"{hd:.0f} dBFS at {mains:.0f} Hz, {over:.0f} dB over "
                  "the floor", f"<= {L.AUDIO_HUM_WARN_DBFS:g} dBFS, "
                  f"<= {L.AUDIO_HUM_OVER_FLOOR_DB:g} dB", None, "piezo-humming",
                  "mains hum: a ground loop or an unshielded piezo lead; use a shielded "
                  "cable grounded at the preamp only, power the hub from the same outlet",
                  dbfs=hd, mains_hz=mains, over_floor_db=over))
    clip = float(np.mean(np.abs(x) >= 0.999))
    st = FAIL if clip > L.AUDIO_CLIP_FAIL else PASS
    out.append(_r("piezo clipping", st, f"{100 * clip:.2f} % of samples",
                  f"<= {100 * L.AUDIO_CLIP_FAIL:g} %", None, "piezo-clipping",
                  "taps clip: lower the preamp gain (its gain resistor) or the card's "
                  "input gain (alsamixer: Mic capture)", fraction=clip))
    hp_floor = float(np.sqrt(np.mean(hp_rest ** 2)))
    onsets = sound_onsets(hp[rest_end:], fs, max(hp_floor, 1e-5), L.AUDIO_TAP_SNR_DB)
    peak = float(np.max(np.abs(hp[rest_end:]))) if len(x) > rest_end else 0.0
    snr = dbfs(peak) - dbfs(hp_floor)
    heard = len(onsets)
    st = FAIL if heard == 0 or snr < L.AUDIO_TAP_SNR_DB else \
        WARN if heard < taps_asked else PASS
    out.append(_r("piezo hears taps", st, f"{heard} heard ({taps_asked} asked), peak "
                  f"{dbfs(peak):.0f} dBFS ({snr:.0f} dB over rest)",
                  f"{taps_asked}, >= {L.AUDIO_TAP_SNR_DB:g} dB",
                  None, "piezo-unplugged",
                  "the taps are not heard: plug the piezo into the preamp, check its two "
                  "solder joints on the disc and that the disc is glued under the nail",
                  heard=heard, snr_db=snr))
    if force_taps and onsets:
        t_sound = [t0 + (rest_end + i) / fs for i in onsets]
        delays = []
        for tf in force_taps:
            j = int(np.argmin([abs(ts - tf) for ts in t_sound]))
            delays.append(t_sound[j] - tf)
        dly = float(np.median(delays)) if delays else float("nan")
        st = WARN if abs(dly) > L.AUDIO_DELAY_WARN_S else PASS
        out.append(_r("tap delay sound - force", st, f"{1e3 * dly:+.0f} ms",
                      f"|x| <= {1e3 * L.AUDIO_DELAY_WARN_S:g} ms", None, "",
                      "force and sound disagree on the tap time: the sound card's latency is "
                      "not compensated (use the ADC timestamps, docs/audio.md)", seconds=dly))
    else:
        out.append(_r("tap delay sound - force", SKIP, "taps not seen in both", ""))
    return out
