"""The per-channel checks: pure functions of recorded segments, each returning
:class:`~.results.Result` objects (no device, no clock: tested directly on arrays).

A :class:`Segment` is what the probe recorded: device times, untared counts (float, NaN where
a chip timed out), and the frames' timeout and saturation masks.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from . import limits as L
from .results import FAIL, PASS, SKIP, WARN, Result

FACES = ("+X", "+Y", "-X", "-Y")
"""Channel i's gauge is on the face whose outward normal points at i x 90 degrees."""
PRESSED_FACE_SIGN = 1
"""Pressing a face (pushing it towards the prism's axis) stretches its gauge: that channel's
counts rise and the opposite face's fall (the paper's quarter bridge, gauge on the top arm;
checked on the virtual unit by tests/check/test_signals.py)."""


@dataclass
class Segment:
    times_s: np.ndarray
    """(N,) device time of each frame, seconds."""
    counts: np.ndarray
    """(N, C) counts, float; NaN where the chip timed out."""
    timeout_mask: np.ndarray
    saturation_mask: np.ndarray

    @property
    def channels(self) -> int:
        return self.counts.shape[1]

    def __len__(self) -> int:
        return len(self.times_s)

    def valid(self, ch: int) -> np.ndarray:
        bad = ((self.timeout_mask | self.saturation_mask) >> ch) & 1
        return (bad == 0) & np.isfinite(self.counts[:, ch])

    def answered(self, ch: int) -> np.ndarray:
        return ((self.timeout_mask >> ch) & 1) == 0


def make_result(check: str, status: str, value: str = "", limit: str = "",
                ch: int | None = None, fault: str = "", fix: str = "", **data) -> Result:
    """A :class:`Result`; the fault is kept for failures only, the fix for failures and
    warnings."""
    return Result(check, status, value, limit, ch, fault if status == FAIL else "",
                  fix if status in (FAIL, WARN) else "", data)


_r = make_result  # short: the checks call it many times


def _live(seg: Segment, skip: set[int]) -> list[int]:
    """The channels not already failed by an earlier check."""
    return [ch for ch in range(seg.channels) if ch not in skip]


def check_chips(seg: Segment) -> list[Result]:
    """Every chip answers: the fraction of readings it timed out in."""
    out = []
    n = max(len(seg), 1)
    for ch in range(seg.channels):
        miss = 1 - float(np.count_nonzero(seg.answered(ch))) / n
        st = FAIL if miss >= L.TIMEOUT_FAIL else WARN if miss > L.TIMEOUT_WARN else PASS
        out.append(_r("chip answers", st, f"{100 * miss:.1f} % missed",
                      f"<= {100 * L.TIMEOUT_WARN:g} %", ch, "missing-chip",
                      f"chip {ch} does not answer: check its VCC/GND, its DOUT and SCK wires "
                      "and their solder joints (reflow them), or replace the chip",
                      missed_fraction=miss))
    return out


def check_rate(seg: Segment, rate_sps: int) -> Result:
    """The chips convert at the set rate (from the spacing of the device timestamps)."""
    if len(seg) < 3:
        return _r(f"rate {rate_sps} SPS", FAIL, "no frames", f"{rate_sps} SPS",
                  fix="no samples arrived: check the 5 V supply of the HX711s and the RATE pin")
    dt = np.diff(seg.times_s)
    measured = 1.0 / float(np.median(dt[dt > 0])) if np.any(dt > 0) else 0.0
    rel = abs(measured - rate_sps) / rate_sps
    st = FAIL if rel > L.RATE_FAIL_REL else WARN if rel > L.RATE_WARN_REL else PASS
    return _r(f"rate {rate_sps} SPS", st, f"{measured:.1f} SPS",
              f"{rate_sps} +-{100 * L.RATE_WARN_REL:g} %",
              fix=f"the chips convert at {measured:.1f} SPS, not {rate_sps}: the RATE pin is "
                  "wired to the wrong level (low = 10 SPS, high = 80 SPS) or the crystal/XI "
                  "is off", measured_sps=measured)


def check_stuck(seg: Segment, skip: set[int] = frozenset()) -> list[Result]:
    """A chip whose DOUT is stuck reads the same value every time (a real one never does)."""
    out = []
    for ch in _live(seg, skip):
        v = seg.counts[seg.answered(ch), ch]
        v = v[np.isfinite(v)]
        if len(v) < 10:
            out.append(_r("DOUT toggles", SKIP, "too few readings", "", ch))
            continue
        distinct = len(np.unique(v))
        if distinct == 1 and v[0] in (-L.COUNTS_FULL_SCALE, L.COUNTS_FULL_SCALE - 1):
            # Pinned at a limit: an open bridge, not DOUT (check_balance names it).
            out.append(_r("DOUT toggles", SKIP, "saturated", "", ch))
            continue
        st = FAIL if distinct == 1 else PASS
        out.append(_r("DOUT toggles", st, f"{distinct} distinct values", "> 1", ch,
                      "stuck-dout", f"chip {ch} reads {v[0]:.0f} every time: its DOUT is stuck "
                      "(a solder bridge to GND/VCC or a broken trace); reflow DOUT",
                      distinct=distinct))
    return out


def _detrended(seg: Segment, ch: int) -> np.ndarray:
    ok = seg.valid(ch)
    v, t = seg.counts[ok, ch], seg.times_s[ok]
    if len(v) < 3:
        return np.empty(0)
    a = np.polyfit(t - t.mean(), v, 1)
    return v - np.polyval(a, t - t.mean())


def noise_rms(seg: Segment, ch: int) -> float:
    """Noise at rest in counts rms (a straight-line drift removed)."""
    d = _detrended(seg, ch)
    return float(np.sqrt(np.mean(d ** 2))) if len(d) else float("nan")


def check_noise(seg: Segment, rate_sps: int, gain: int = L.GAIN,
                skip: set[int] = frozenset()) -> list[Result]:
    """Noise at rest against the datasheet's figure for this rate and gain."""
    exp = L.expected_noise_counts(rate_sps, gain)
    out = []
    for ch in _live(seg, skip):
        rms = noise_rms(seg, ch)
        x = rms / exp
        st = SKIP if not np.isfinite(x) else FAIL if x > L.NOISE_FAIL_X else \
            WARN if x > L.NOISE_WARN_X else PASS
        out.append(_r("noise at rest", st, f"{rms:.0f} counts rms ({x:.1f}x)",
                      f"{exp:.0f} x{L.NOISE_WARN_X:g}", ch, "noisy-channel",
                      f"channel {ch} is {x:.0f}x noisier than the HX711 should be: check its "
                      "ground and E- wire, twist and shorten the bridge leads, keep them away "
                      "from motor and USB cables", rms_counts=rms, expected=exp, ratio=x))
    return out


def mains_alias_hz(mains_hz: float, rate_sps: float) -> float:
    """Where ``mains_hz`` lands after sampling at ``rate_sps`` (50 Hz at 80 SPS -> 30 Hz)."""
    return abs(mains_hz - rate_sps * round(mains_hz / rate_sps))


def tone_rms(t: np.ndarray, v: np.ndarray, hz: float) -> float:
    """Rms of the sine at ``hz`` in ``v`` (least squares, any sampling)."""
    if len(v) < 4:
        return 0.0
    a = np.column_stack([np.sin(2 * np.pi * hz * t), np.cos(2 * np.pi * hz * t),
                         np.ones_like(t)])
    coef, *_ = np.linalg.lstsq(a, v, rcond=None)
    return float(np.hypot(coef[0], coef[1]) / np.sqrt(2))


def check_mains(seg: Segment, rate_sps: int, gain: int = L.GAIN,
                skip: set[int] = frozenset()) -> list[Result]:
    """50/60 Hz pick-up, seen at its alias (needs 80 SPS: at 10 SPS both land on DC)."""
    out = []
    exp = L.expected_noise_counts(rate_sps, gain)
    for ch in _live(seg, skip):
        ok = seg.valid(ch)
        d = _detrended(seg, ch)
        t = seg.times_s[ok]
        if rate_sps < 40 or len(d) < 20:
            out.append(_r("50/60 Hz pick-up", SKIP, "needs 80 SPS", "", ch))
            continue
        amp = max(tone_rms(t, d, mains_alias_hz(m, rate_sps)) for m in (50.0, 60.0))
        st = WARN if amp > L.MAINS_WARN_X * exp else PASS
        out.append(_r("50/60 Hz pick-up", st, f"{amp:.0f} counts rms",
                      f"<= {L.MAINS_WARN_X * exp:.0f}", ch, "",
                      f"channel {ch} picks up mains: shorten and twist the bridge leads, ground "
                      "the shield at one end", rms_counts=amp))
    return out


def check_balance(seg: Segment, skip: set[int] = frozenset()) -> list[Result]:
    """Untared level at rest as a fraction of full scale, and saturation."""
    out = []
    for ch in _live(seg, skip):
        ans = seg.answered(ch)
        sat = float(np.mean(((seg.saturation_mask[ans] >> ch) & 1) == 1)) if ans.any() else 0.0
        v = seg.counts[ans, ch]
        frac = float(np.nanmean(v)) / L.COUNTS_FULL_SCALE if len(v) else float("nan")
        if sat > 0.5 or abs(frac) >= L.BALANCE_FAIL:
            st = FAIL
        else:
            st = WARN if abs(frac) > L.BALANCE_WARN or sat > 0 else PASS
        out.append(_r("bridge balance", st, f"{100 * frac:+.1f} % FS"
                      + (f", {100 * sat:.0f} % saturated" if sat else ""),
                      f"|x| <= {100 * L.BALANCE_WARN:g} % FS", ch, "open-bridge",
                      f"channel {ch} sits at {100 * frac:+.0f} % of full scale: the bridge is "
                      "open or unbalanced (a broken gauge lead, a cold joint, a cracked or "
                      "unglued gauge, or a wrong completion resistor); measure the gauge "
                      "(120 ohm) and the resistors", fraction=frac, saturated=sat))
    return out


def check_drift(seg: Segment, rate_sps: int, gain: int = L.GAIN,
                skip: set[int] = frozenset()) -> list[Result]:
    """Drift of the level at rest (nothing touching it), as counts per minute."""
    exp = L.expected_noise_counts(rate_sps, gain)
    out = []
    for ch in _live(seg, skip):
        ok = seg.valid(ch)
        if np.count_nonzero(ok) < 10:
            out.append(_r("drift at rest", SKIP, "too few readings", "", ch))
            continue
        t = seg.times_s[ok] - seg.times_s[ok].mean()
        coef = np.polyfit(t, seg.counts[ok, ch], 1)
        resid = seg.counts[ok, ch] - np.polyval(coef, t)
        se = float(np.std(resid) / np.sqrt(np.sum(t ** 2))) * 60.0
        slope = float(coef[0]) * 60.0
        lim = L.DRIFT_WARN_X * exp
        st = WARN if abs(slope) > max(lim, L.DRIFT_SIGNIFICANCE * se) else PASS
        out.append(_r("drift at rest", st, f"{slope:+.0f} +-{se:.0f} counts/min",
                      f"|x| <= {lim:.0f}",
                      ch, "", f"channel {ch} drifts at rest: let the board warm up for 10 "
                      "minutes, keep it out of drafts; if it stays, re-glue the gauge",
                      counts_per_min=slope))
    return out


def check_return(before: Segment, after: Segment, press: np.ndarray | None,
                 skip: set[int] = frozenset()) -> list[Result]:
    """How far each channel stays off zero after the presses, against its press response
    (some hysteresis and creep is normal; a gauge that slips in its glue keeps much more)."""
    out = []
    for ch in _live(before, skip):
        a, b = before.counts[before.valid(ch), ch], after.counts[after.valid(ch), ch]
        if not len(a) or not len(b) or press is None or not press[ch]:
            out.append(_r("return to zero", SKIP, "no presses", "", ch))
            continue
        frac = float(np.median(b) - np.median(a)) / abs(float(press[ch]))
        st = WARN if abs(frac) > L.RETURN_WARN else PASS
        out.append(_r("return to zero", st, f"{100 * frac:+.1f} % of a press",
                      f"|x| <= {100 * L.RETURN_WARN:g} %", ch, "",
                      f"channel {ch} stays {100 * frac:+.0f} % off after a press: the gauge "
                      "creeps in its glue (re-glue it) or the prism rubs on the cap",
                      fraction=frac))
    return out


# --- guided presses ---------------------------------------------------------------------

def press_response(seg: Segment, noise: np.ndarray, skip: set[int] = frozenset(),
                   baseline: int = 6) -> np.ndarray | None:
    """Change of each channel at the press's peak from the level before it; None when the
    press did not move any channel by :data:`~.limits.PRESS_MIN_X` noise rms."""
    c = seg.channels
    good = [ch for ch in range(c) if ch not in skip]
    if len(seg) < baseline + 3 or not good:
        return None
    x = seg.counts[:, good].copy()
    base = np.nanmedian(x[:baseline], axis=0)
    d = x - base
    d[~np.isfinite(d)] = 0.0
    z = d / np.maximum(noise[good], 1.0)
    mag = np.sqrt(np.sum(z ** 2, axis=1))
    k = int(np.argmax(mag))
    if mag[k] < L.PRESS_MIN_X:
        return None
    # The hold of the press: every reading within 20 % of the peak (robust to where in a
    # flat top the noise puts the maximum).
    top = mag >= 0.8 * mag[k]
    out = np.zeros(c)
    out[good] = d[top].mean(axis=0)
    return out


def expected_response(face: int, channels: int = 4) -> np.ndarray:
    e = np.zeros(channels)
    e[face % channels] = PRESSED_FACE_SIGN
    e[(face + 2) % channels] = -PRESSED_FACE_SIGN
    return e


def solve_mapping(responses: dict[int, np.ndarray], skip: set[int] = frozenset(),
                  tolerance: float = 0.85) -> tuple[list[int], list[int], np.ndarray]:
    """Which face's gauge each channel carries, and its sign, from the presses.

    ``responses``: pressed face -> (4,) change of each channel. Returns ``(slot, sign,
    score)``: channel i reads the gauge of face ``slot[i]`` with sign ``sign[i]``; ``score``
    (4, 4) the agreement of channel i with face j's expected pattern. Opposite faces give
    mirror patterns, so several explanations can fit equally: among those within
    ``tolerance`` of the best, the one with the fewest reversed channels, then the fewest
    moved ones, wins (the simplest wiring mistake).
    """
    faces = sorted(responses)
    c = 4
    r = np.array([responses[f] for f in faces])                      # (F, C)
    scale = np.max(np.abs(r)) or 1.0
    r = r / scale
    e = np.array([[expected_response(f)[j] for f in faces] for j in range(c)])  # (slot, F)
    score = r.T @ e.T                                                 # (C, slot)
    free = [ch for ch in range(c) if ch not in skip]
    slots_free = free  # skipped channels keep their place
    cands = []
    for perm in itertools.permutations(slots_free):
        slot = list(range(c))
        for ch, s in zip(free, perm, strict=True):
            slot[ch] = s
        tot = sum(abs(score[ch, slot[ch]]) for ch in free)
        negs = sum(score[ch, slot[ch]] < 0 for ch in free)
        moved = sum(slot[ch] != ch for ch in free)
        cands.append((tot, negs, moved, slot))
    best = max(cd[0] for cd in cands)
    ok = [cd for cd in cands if cd[0] >= tolerance * best]
    tot, negs, moved, slot = min(ok, key=lambda cd: (cd[1], cd[2], -cd[0]))
    sign = [1 if ch in skip or score[ch, slot[ch]] >= 0 else -1 for ch in range(c)]
    return slot, sign, score


def check_presses(responses: dict[int, np.ndarray | None], skip: set[int] = frozenset()
                  ) -> tuple[list[Result], dict | None]:
    """Polarity, channel mapping and sensitivity from the guided presses."""
    out: list[Result] = []
    seen = {f: r for f, r in responses.items() if r is not None}
    for f, r in responses.items():
        if r is None:
            out.append(_r(f"press {FACES[f]}", FAIL, "no response", "", None, "",
                          f"pressing the {FACES[f]} face moved no channel: press harder, or "
                          "check that the prism is glued to the base and the cap"))
    if len(seen) < 2:
        return out, None
    slot, sign, score = solve_mapping(seen, skip)
    mapping = {"slot": slot, "sign": sign,
               "channel_map": [slot.index(j) for j in range(4)]}
    swapped = [ch for ch in range(4) if slot[ch] != ch and ch not in skip]
    for ch in range(4):
        if ch in skip:
            continue
        if ch in swapped:
            other = slot[ch]
            out.append(_r("channel mapping", FAIL, f"reads the {FACES[other]} gauge",
                          f"{FACES[ch]} gauge", ch, "swapped-data",
                          f"chips {ch} and {other} have their DOUT (data) wires swapped: swap "
                          f"them back (or keep channel_map {mapping['channel_map']} from the "
                          "JSON report: a calibration learns any channel order)"))
        else:
            out.append(_r("channel mapping", PASS, f"{FACES[ch]} gauge",
                                   f"{FACES[ch]} gauge",
                          ch))
        st = FAIL if sign[ch] < 0 else PASS
        out.append(_r("polarity", st, "reversed" if sign[ch] < 0 else "as expected",
                      "pressed face rises", ch, "reversed-gauge",
                      f"channel {ch} is reversed: swap its A+ and A- (or E+ and E-) wires at "
                      "the HX711 (or keep the sign in the JSON report's mapping: a "
                      "calibration learns any sign)"))
    # Sensitivity: each channel's agreement with its face's pattern, against the others'.
    own = np.array([abs(score[ch, slot[ch]]) for ch in range(4)])
    good = [ch for ch in range(4) if ch not in skip]
    med = float(np.median(own[good])) if good else 0.0
    for ch in good:
        rel = own[ch] / med if med > 0 else 0.0
        st = FAIL if rel < L.SENSITIVITY_FAIL else WARN if rel < L.SENSITIVITY_WARN else PASS
        out.append(_r("sensitivity", st, f"{100 * rel:.0f} % of median",
                      f">= {100 * L.SENSITIVITY_WARN:g} %", ch, "loose-gauge",
                      f"channel {ch} responds at {100 * rel:.0f} % of the others: its gauge "
                      "is loose or badly glued (re-glue it with thin cyanoacrylate, pressed "
                      "flat for a minute), or its gain resistor is wrong", relative=rel))
    mapping["sensitivity_relative"] = (own / med if med > 0 else own).round(3).tolist()
    mapping["press_counts"] = [float(max(abs(r[ch]) for r in seen.values())) for ch in range(4)]
    return out, mapping
