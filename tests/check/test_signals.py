"""The check's pure functions on arrays built for each case (no device)."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from fingertip.check import limits as L
from fingertip.check import signals as S
from fingertip.check.piezo import check_piezo, force_tap_times, hum_rms
from fingertip.check.results import FAIL, PASS, SKIP, WARN, Report, Result

RATE = 80
NOISE = L.expected_noise_counts(RATE)


def seg(counts, times=None, tmask=None, smask=None) -> S.Segment:
    c = np.asarray(counts, float)
    n = len(c)
    t = np.arange(n) / RATE if times is None else np.asarray(times, float)
    return S.Segment(t, c, np.zeros(n, np.int64) if tmask is None else np.asarray(tmask),
                     np.zeros(n, np.int64) if smask is None else np.asarray(smask))


def rest(n=200, offsets=(1e5, -2e5, 3e4, 5e5), noise=NOISE, seed=0) -> S.Segment:
    rng = np.random.default_rng(seed)
    return seg(np.asarray(offsets) + rng.normal(0, noise, (n, 4)))


def by(results, check):
    return {r.channel: r for r in results if r.check == check}


def test_clean_rest_passes_every_channel_check():
    s = rest()
    for fn in (S.check_chips, S.check_stuck, S.check_balance):
        assert all(r.status == PASS for r in fn(s)), fn.__name__
    assert all(r.status == PASS for r in S.check_noise(s, RATE))
    assert all(r.status == PASS for r in S.check_mains(s, RATE))
    assert all(r.status == PASS for r in S.check_drift(s, RATE))
    assert S.check_rate(s, RATE).status == PASS


def test_missing_chip_fails_and_is_named():
    s = rest()
    s.timeout_mask[:] = 0b0100
    s.counts[:, 2] = np.nan
    r = by(S.check_chips(s), "chip answers")
    assert r[2].status == FAIL and r[2].fault == "missing-chip" and "chip 2" in r[2].fix
    assert r[0].status == PASS


def test_a_few_timeouts_warn():
    s = rest()
    s.timeout_mask[:5] = 1
    assert by(S.check_chips(s), "chip answers")[0].status == WARN


def test_rate_measured_from_device_times():
    s = rest()
    assert S.check_rate(seg(s.counts, np.arange(200) / 10.0), RATE).status == FAIL
    assert S.check_rate(seg(s.counts, np.arange(200) / 86.0), RATE).status == PASS
    assert S.check_rate(seg(s.counts, np.arange(200) / 95.0), RATE).status == WARN
    assert S.check_rate(seg(np.zeros((1, 4))), RATE).status == FAIL


def test_stuck_dout_reads_one_value():
    s = rest()
    s.counts[:, 1] = 0.0
    r = by(S.check_stuck(s), "DOUT toggles")
    assert r[1].status == FAIL and r[1].fault == "stuck-dout"
    assert r[0].status == PASS


def test_pinned_at_full_scale_is_the_bridge_not_dout():
    s = rest()
    s.counts[:, 3] = L.COUNTS_FULL_SCALE - 1
    s.saturation_mask[:] = 0b1000
    assert by(S.check_stuck(s), "DOUT toggles")[3].status == SKIP
    b = by(S.check_balance(s), "bridge balance")
    assert b[3].status == FAIL and b[3].fault == "open-bridge"
    assert b[0].status == PASS


@pytest.mark.parametrize("frac,status", [(0.1, PASS), (-0.6, WARN), (0.95, FAIL)])
def test_balance_as_fraction_of_full_scale(frac, status):
    s = rest(offsets=(frac * L.COUNTS_FULL_SCALE, 0, 0, 0))
    assert by(S.check_balance(s), "bridge balance")[0].status == status


def test_noise_against_the_datasheet():
    s = rest(noise=NOISE)
    s.counts[:, 2] += np.random.default_rng(1).normal(0, NOISE * 10, len(s))
    s.counts[:, 1] += np.random.default_rng(2).normal(0, NOISE * 3, len(s))
    r = by(S.check_noise(s, RATE), "noise at rest")
    assert r[2].status == FAIL and r[2].fault == "noisy-channel"
    assert r[1].status == WARN and r[1].fault == ""  # only failures name a fault
    assert r[0].status == PASS
    # At 10 SPS the datasheet's noise is lower: the same counts are noisier relative to it.
    assert L.expected_noise_counts(10) < L.expected_noise_counts(80)
    assert L.expected_noise_counts(80, gain=64) == pytest.approx(NOISE / 2)


def test_noise_ignores_a_straight_drift():
    s = rest()
    s.counts[:, 0] += np.arange(len(s)) * 50.0
    assert by(S.check_noise(s, RATE), "noise at rest")[0].status == PASS
    assert by(S.check_drift(s, RATE), "drift at rest")[0].status == WARN


def test_drift_needs_significance():
    """White noise alone must not be called drift, however the slope happens to fall."""
    warned = sum(r.status == WARN for k in range(40) for r in S.check_drift(rest(seed=k), RATE))
    assert warned == 0


def test_mains_alias():
    assert S.mains_alias_hz(50, 80) == 30
    assert S.mains_alias_hz(60, 80) == 20
    assert S.mains_alias_hz(50, 10) == 0
    s = rest()
    s.counts[:, 3] += 5 * NOISE * np.sqrt(2) * np.sin(2 * np.pi * 30 * s.times_s)
    r = by(S.check_mains(s, RATE), "50/60 Hz pick-up")
    assert r[3].status == WARN and r[0].status == PASS
    assert all(x.status == SKIP for x in S.check_mains(s, 10))


def test_tone_rms_exact():
    t = np.arange(400) / 80
    assert S.tone_rms(t, 3 * np.sin(2 * np.pi * 20 * t + 1), 20) == pytest.approx(3 / np.sqrt(2))


def _responses(slot=(0, 1, 2, 3), sign=(1, 1, 1, 1), gain=(1, 1, 1, 1), faces=range(4)):
    out = {}
    for f in faces:
        e = S.expected_response(f)
        out[f] = np.array([sign[ch] * gain[ch] * e[slot[ch]] for ch in range(4)]) * 2e5
    return out


def test_mapping_identity():
    slot, sign, _ = S.solve_mapping(_responses())
    assert slot == [0, 1, 2, 3] and sign == [1, 1, 1, 1]


@pytest.mark.parametrize("a,b", list(itertools.combinations(range(4), 2)))
def test_every_swapped_pair_is_named(a, b):
    slot = list(range(4))
    slot[a], slot[b] = b, a
    res, mapping = S.check_presses(_responses(slot=slot))
    failed = {r.channel for r in res if r.status == FAIL}
    assert failed == {a, b}
    assert {r.fault for r in res if r.status == FAIL} == {"swapped-data"}
    assert mapping["channel_map"][a] == b


@pytest.mark.parametrize("ch", range(4))
def test_every_reversed_channel_is_named(ch):
    sign = [1] * 4
    sign[ch] = -1
    res, mapping = S.check_presses(_responses(sign=sign))
    assert [(r.channel, r.fault) for r in res if r.status == FAIL] == [(ch, "reversed-gauge")]
    assert mapping["sign"][ch] == -1


def test_two_presses_suffice_and_none_is_a_failure():
    res, mapping = S.check_presses(_responses(faces=(0, 1)))
    assert mapping is not None and not [r for r in res if r.status == FAIL]
    res, mapping = S.check_presses({0: None, 1: None})
    assert mapping is None and len([r for r in res if r.status == FAIL]) == 2


def test_loose_gauge_low_sensitivity():
    res, _ = S.check_presses(_responses(gain=(1, 0.15, 1.1, 0.9)))
    assert [(r.channel, r.fault) for r in res if r.status == FAIL] == [(1, "loose-gauge")]


def test_skipped_channels_keep_their_place():
    r = _responses()
    for v in r.values():
        v[2] = 0.0
    res, mapping = S.check_presses(r, skip={2})
    assert mapping["slot"][2] == 2 and not [x for x in res if x.status == FAIL]


def test_press_response_and_no_press():
    s = rest(n=100)
    noise = np.full(4, NOISE)
    assert S.press_response(s, noise) is None
    s.counts[40:60, 0] += 1e5
    s.counts[40:60, 2] -= 1e5
    r = S.press_response(s, noise)
    assert r[0] == pytest.approx(1e5, rel=0.01) and r[2] == pytest.approx(-1e5, rel=0.01)
    assert S.press_response(seg(np.zeros((3, 4))), noise) is None


def test_pressed_face_sign_matches_the_physics():
    """The convention the mapping relies on, from the virtual unit's beam and bridge model."""
    from fingertip.sim.physics import VirtualStrainSensor

    sens = VirtualStrainSensor(None, variation=False)
    for face in range(4):
        a = np.radians(face * 90 + 180)  # pressing the face pushes towards its opposite
        c0 = sens.counts_batch(np.zeros((1, 2)), 2.0, [0.0])[0]
        sens.reset()
        c1 = sens.counts_batch(2 * np.array([[np.cos(a), np.sin(a)]]), 2.0, [0.0])[0]
        sens.reset()
        d = (c1 - c0).astype(float)
        assert np.sign(d[face]) == S.PRESSED_FACE_SIGN
        assert np.sign(d[(face + 2) % 4]) == -S.PRESSED_FACE_SIGN


def test_return_to_zero():
    a, b = rest(n=80), rest(n=80, seed=5)
    press = np.full(4, 2e5)
    assert all(r.status == PASS for r in S.check_return(a, b, press))
    b.counts[:, 1] += 0.3 * 2e5
    assert by(S.check_return(a, b, press), "return to zero")[1].status == WARN
    assert all(r.status == SKIP for r in S.check_return(a, b, None))


# --- piezo ---------------------------------------------------------------------------------

FS = 44100


def audio(seconds=1.5, hum=1e-3, noise=3e-5, taps=(0.5, 0.85, 1.2), tap_amp=0.2, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * FS)) / FS
    x = hum * np.sqrt(2) * np.sin(2 * np.pi * 50 * t) + rng.normal(0, noise, len(t))
    for tt in taps:
        k = int(tt * FS)
        m = np.arange(400)
        x[k:k + 400] += tap_amp * np.exp(-m / 60) * np.sin(2 * np.pi * 2300 * m / FS)
    return np.clip(x, -1, 1 - 2 ** -15)


def piezo(x, taps=(0.5, 0.85, 1.2), t0=0.0):
    return {r.check: r for r in check_piezo(x, FS, t0, list(taps), 3, "card")}


def test_piezo_clean():
    r = piezo(audio())
    assert all(v.status == PASS for v in r.values()), {k: v.value for k, v in r.items()}
    assert abs(r["tap delay sound - force"].data["seconds"]) < 2e-3


def test_piezo_delay_measured():
    r = piezo(audio(), taps=(0.47, 0.82, 1.17))
    assert r["tap delay sound - force"].data["seconds"] == pytest.approx(0.03, abs=2e-3)
    r = piezo(audio(), taps=(0.4, 0.75, 1.1))
    assert r["tap delay sound - force"].status == WARN


def test_piezo_unplugged_clipping_humming():
    r = piezo(audio(hum=0, noise=3e-5, tap_amp=0))
    assert r["piezo hears taps"].fault == "piezo-unplugged"
    r = piezo(audio(tap_amp=3.0))
    assert r["piezo clipping"].fault == "piezo-clipping"
    r = piezo(audio(hum=0.04))
    assert r["piezo hum"].fault == "piezo-humming"
    assert r["piezo hears taps"].status == PASS  # hum does not hide the taps
    # Everything louder (a preamp gain too high): hum warns, it is not a ground loop.
    r = piezo(audio(hum=0.04, noise=3e-5 * 40))
    assert r["piezo hum"].status == WARN


def test_piezo_none_and_dc():
    assert check_piezo(None, FS, 0, [], 3)[0].status == SKIP
    r = piezo(audio() + 0.1)
    assert r["piezo DC offset"].status == WARN


def test_piezo_empty_capture_fails_with_a_fix():
    # a card unplugged during the taps delivers nothing: a clear failure, not a crash
    r = check_piezo(np.zeros(0, np.float32), FS, 0.0, [0.5], 3, "card")
    assert [(x.check, x.status) for x in r] == [("piezo", FAIL)]
    assert "no samples" in r[0].value and "plugged in" in r[0].fix


def test_hum_rms_of_a_known_tone():
    t = np.arange(FS) / FS
    h, m = hum_rms(0.01 * np.sqrt(2) * np.sin(2 * np.pi * 60 * t), FS)
    assert m == 60 and h == pytest.approx(0.01, rel=0.05)
    assert hum_rms(np.zeros(10), FS)[0] == 0.0


def test_force_tap_times_one_per_tap():
    s = rest(n=160)
    for k in (40, 68, 96):
        s.counts[k:k + 4, 1] += 5e4
    s.counts[100:, 1] += 3e3  # a residual step afterwards (hysteresis) is not a tap
    t = force_tap_times(s, np.full(4, NOISE))
    assert len(t) == 3
    assert t[0] == pytest.approx(39.5 / RATE)


def test_report_table_json_and_exit(tmp_path):
    rep = Report()
    rep.add(Result("a", PASS, "1", "2"))
    rep.add(Result("b", FAIL, "3", "4", 2, "open-bridge", "fix it"))
    rep.skipped_steps.append("press +X")
    assert rep.exit_code() == 1 and rep.faults == {"open-bridge"}
    text = rep.table()
    assert "FAIL b ch2: fix it" in text and "skipped (--no-prompt): press +X" in text
    import json

    d = json.loads(rep.write_json(tmp_path / "r.json").read_text())
    assert d["ok"] is False and d["faults"] == ["open-bridge"]
    rep.results.pop()
    assert rep.exit_code() == 0
