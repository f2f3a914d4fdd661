"""Frames lost across outages and restarts nobody announced: the pure arithmetic of
fingertip.device.outage (table-driven, wraparounds included), then a Fingertip on a pty
whose device is unplugged and comes back, restarted or not."""
from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass

import pytest

from fingertip import Fingertip
from fingertip.device.outage import (
    SEQ_MODULUS, TIME_MODULUS, OutageTracker, continued, device_gap_us, frames_missing, seq_gap,
)
from fingertip.sim import VirtualFirmware
from fingertip.sim.device.pty_device import PtyDevice

from .waiting import PATIENCE, wait_for

P = 0.0125  # 80 Hz
P_US = 12_500


@dataclass
class F:
    seq: int
    device_time_us: int
    host_time: float
    arrival_time: float = math.nan


def stream(seq0: int, us0: int, t0: float, n: int) -> list[F]:
    """``n`` frames one period apart, numbers and device time wrapping as the device's."""
    return [F((seq0 + k) % SEQ_MODULUS, (us0 + k * P_US) % TIME_MODULUS, t0 + k * P)
            for k in range(n)]


@pytest.mark.parametrize("before, after, gap", [
    (5, 6, 0), (5, 7, 1), (206, 5, (5 - 206 - 1) % 65536),
    (65535, 0, 0), (65534, 1, 2), (65535, 65535, 65535),
])
def test_sequence_gaps_wrap_at_16_bits(before, after, gap):
    assert seq_gap(before, after) == gap


@pytest.mark.parametrize("before, after, us", [
    (1_000, 13_500, 12_500), (TIME_MODULUS - 2_500, 10_000, 12_500),
    (TIME_MODULUS - 1, 0, 1), (3_000_000, 0, TIME_MODULUS - 3_000_000),
])
def test_device_time_gaps_wrap_at_32_bits(before, after, us):
    assert device_gap_us(before, after) == us


# (case, last frame before, first frame after, restart announced, lost, restarted)
CASES = [
    # The device ran on through a 1 s link loss: 79 frames between, by its own clock.
    ("ran on", F(100, 5_000_000, 10.0), F(180, 6_000_000, 10.0 + 1.0), False, 79, False),
    # ... across the 16-bit wrap of sequence numbers.
    ("seq wraps", F(65500, 5_000_000, 10.0), F(44, 6_000_000, 11.0), False, 79, False),
    # ... across the 32-bit wrap of device microseconds (after 71.6 minutes).
    ("time wraps", F(100, TIME_MODULUS - 500_000, 4295.0), F(180, 500_000, 4296.0), False,
     79, False),
    # Gone 2.65 s, back restarted: sequence 206 -> 5, device time back near 0. The host
    # clock over the nominal period says 211 frames are missing; a restart is inferred.
    ("restart inferred", F(206, 2_575_000, 50.0), F(5, 40_000, 52.65), False, 211, True),
    # The same with its boot INFO seen: the same frames, the restart already counted.
    ("restart announced", F(206, 2_575_000, 50.0), F(5, 40_000, 52.65), True, 211, True),
    # Restarted, and its young clock happens to be later than the old one's: still a
    # restart (device time advanced 0.5 s while the host's did 2.65 s).
    ("young clock ahead", F(40, 500_000, 50.0), F(5, 1_000_000, 52.65), False, 211, True),
    # Device time agrees but the numbers went back: a restart.
    ("numbers went back", F(3000, 5_000_000, 10.0), F(3, 6_000_000, 11.0), False, 79, True),
    # No frame missing: the next frame came one period later.
    ("nothing missing", F(7, 1_000_000, 3.0), F(8, 1_012_500, 3.0125), False, 0, False),
    # The very next frame, 0.63 s later by the host's stamps: held up on the way across
    # the break (a buffer that kept it), not lost, and no restart.
    ("held up", F(29, 362_500, 10.0), F(30, 375_000, 10.63), False, 0, False),
    # The stamps before the break were late (the host was busy as the stream began, and
    # the map's line fell when on-time frames came): the device's clock ran 0.29 s more
    # than the stamps say. It ran on; counted by its clock and numbers.
    ("late stamps before", F(7, 75_000, 10.3), F(80, 987_500, 10.92), False, 72, False),
    # A clock 4.4 s ahead of the stamps is no late stamp: not the device that ran on.
    ("clock far ahead", F(7, 75_000, 10.0), F(80, 5_075_000, 10.62), False, 49, True),
    # No clock map on the host yet: arrival times stand in.
    ("arrival times", F(7, 1_000_000, math.nan, 3.0), F(5, 10_000, math.nan, 4.0), False,
     79, True),
]


@pytest.mark.parametrize("case, before, after, announced, lost, restarted", CASES,
                         ids=[c[0] for c in CASES])
def test_frames_missing_across_one_outage(case, before, after, announced, lost, restarted):
    assert continued(before, after, P) is not restarted or announced
    assert frames_missing(before, after, P, restarted) == lost
    t = OutageTracker()
    t.frame(before)
    if announced:
        t.reset_seen(P)
    else:
        t.link_lost(P, before.host_time + 0.1)
    o = t.frame(after)
    assert o is not None and (o.frames_lost, o.restarted, o.reset_announced) == (
        lost, restarted, announced)
    assert t.outage_frames == lost and t.outages == 1
    assert t.device_resets == int(restarted)  # counted once, announced or inferred


def test_a_device_that_ran_on_never_lost_more_than_its_numbers_skipped():
    # Its clock says 79 frames, its numbers 49: each frame took one, so 49 at most.
    assert frames_missing(F(100, 5_000_000, 10.0), F(150, 6_000_000, 11.0), P, False) == 49
    # Numbers that advanced less than one per period mean another device (a restart).
    assert not continued(F(100, 5_000_000, 10.0), F(150, 6_000_000, 11.0), P)


def test_the_period_the_frames_kept_replaces_the_nominal_one():
    # An HX711 whose oscillator runs 4 % fast: 83.2 frames a second, not 80.
    period_us = 12_019
    t = OutageTracker()
    for k in range(400):  # 4.8 s
        t.frame(F(k, k * period_us, k * period_us * 1e-6))
    t.link_lost(P, 5.0)
    # Gone 2.65 s, back restarted: 219 frames at its own period (211 at the nominal one).
    last = 399 * period_us * 1e-6
    assert t.frame(F(2, 30_000, last + 2.65)).frames_lost == round(2.65e6 / period_us) - 1
    # A period far from the nominal one (the rate was changed since) is not used.
    t = OutageTracker()
    for k in range(400):
        t.frame(F(k, k * 100_000, k * 0.1))
    t.link_lost(P, 40.0)
    assert t.frame(F(2, 30_000, 39.9 + 1.0)).frames_lost == 79


def test_a_stream_without_breaks_loses_nothing_whatever_wraps():
    t = OutageTracker()
    for f in stream(65_000, TIME_MODULUS - 2_000_000, 100.0, 2_000):
        assert t.frame(f) is None
    assert (t.outage_frames, t.device_resets, t.outages) == (0, 0, 0)


def test_several_outages_add_up_and_gone_time_runs_while_away():
    t = OutageTracker()
    a = stream(0, 0, 0.0, 100)
    for f in a:
        t.frame(f)
    assert t.gone_for(5.0) is None  # connected: not gone
    t.link_lost(P, a[-1].host_time + 0.05)
    assert t.gone_for(a[-1].host_time + 3.0) == pytest.approx(3.0)
    # The device ran on: frames 100..179 were sent while the link was away.
    b = stream(180, 180 * P_US, 180 * P, 50)
    assert t.frame(b[0]).frames_lost == 80
    for f in b[1:]:
        t.frame(f)
    assert t.gone_for(100.0) is None
    # Then it reset on the same link (boot INFO), and streamed again 0.4 s later.
    t.reset_seen(P)
    c = stream(3, 0, b[-1].host_time + 0.4, 10)
    assert t.frame(c[0]).frames_lost == 31
    assert (t.outage_frames, t.device_resets, t.outages) == (111, 1, 2)


def test_a_break_before_any_frame_measures_nothing():
    t = OutageTracker()
    t.link_lost(P, 1.0)
    assert t.frame(F(5, 1_000, 2.0)) is None
    assert (t.outage_frames, t.outages) == (0, 0)


@pytest.mark.parametrize("period", [0.0, -1.0, math.inf, math.nan])
def test_a_nonsense_period_is_refused(period):
    with pytest.raises(ValueError, match="frame period"):
        OutageTracker().link_lost(period, 0.0)


# --- a Fingertip whose device goes away and comes back ------------------------------------

def frames_around_outage(dev: PtyDevice, ft: Fingertip, away_s: float, reboot: bool):
    """(last frame before, first frame after) an unplug of ``away_s`` seconds."""
    ft.start()
    assert ft.read(timeout=1.0) is not None
    time.sleep(0.3)
    dev.unplug()
    assert wait_for(lambda: ft.status == "reconnecting", PATIENCE)
    assert ft.gone_s is not None and ft.gone_s >= 0
    time.sleep(away_s)
    assert ft.gone_s >= away_s  # how long it has been gone, while it is
    dev.replug(reboot=reboot)
    assert wait_for(lambda: ft.stats.outage_frames > 0, PATIENCE)
    # Found by the device's clock, not the host's: a busy host can hold two consecutive
    # frames apart for longer than the outage. The counter moves as the first frame after
    # the break is handed out, a moment before it is queued: drain until it is there.
    frames: list = []

    def across() -> int | None:
        frames.extend(ft.drain())
        steps = [b.device_time_us - a.device_time_us
                 for a, b in itertools.pairwise(frames)]
        if reboot:  # its clock began again
            return next((i for i, s in enumerate(steps) if s < 0), None)
        k = max(range(len(steps)), key=steps.__getitem__, default=None)  # the one long step
        return k if k is not None and steps[k] > away_s * 1e6 else None

    assert wait_for(lambda: across() is not None, PATIENCE)
    k = across()
    assert ft.gone_s is None
    return frames[k], frames[k + 1]


def test_device_that_ran_on_counts_the_frames_it_sent_while_away(tmp_path):
    with PtyDevice(VirtualFirmware(4), link=tmp_path / "ft") as dev, \
            Fingertip(str(dev.link)) as ft:
        before, after = frames_around_outage(dev, ft, 0.6, reboot=False)
        st = ft.stats
        # Exactly the frames its clock says it made meanwhile; its numbers skipped those and
        # the answers to the host's set-up commands after the reconnect.
        assert st.outage_frames == (after.device_time_us - before.device_time_us) // P_US - 1
        assert st.outage_frames <= seq_gap(before.seq, after.seq) <= st.outage_frames + 8
        assert st.outage_frames >= 0.6 / P
        assert st.frames_lost == st.outage_frames and st.device_resets == 0
        assert st.reconnects == 1


def test_device_that_restarted_counts_a_reset_and_the_frames_by_the_host_clock(tmp_path):
    with PtyDevice(VirtualFirmware(4), link=tmp_path / "ft") as dev, \
            Fingertip(str(dev.link)) as ft:
        before, after = frames_around_outage(dev, ft, 0.8, reboot=True)
        st = ft.stats
        assert after.device_time_us < before.device_time_us  # its clock began again
        expected = round((after.host_time - before.host_time) / P) - 1
        assert st.outage_frames == expected and expected >= 0.8 / P
        assert st.frames_lost == st.outage_frames
        assert st.device_resets == 1 and st.reconnects == 1
