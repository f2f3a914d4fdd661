"""Force and audio aligned to within 1 ms with +-100 ppm clock errors and a known offset."""
from __future__ import annotations

import pytest

from tests.firmware.in_loop.alignment import MIN_ON_TIME_S, measure


@pytest.mark.realtime
@pytest.mark.slow
@pytest.mark.usefixtures("fil_builds")
@pytest.mark.parametrize("device_ppm, audio_ppm", [(100.0, -100.0), (-100.0, 100.0)])
def test_force_and_audio_align_within_1ms(device_ppm, audio_ppm, tmp_path):
    # The truth is simavr's pacing line. On a starved host simavr itself can run up to 2 s
    # behind it for 20 s (busy series 20 run 2: 0 and 0.5 s of on-time frames in the map's
    # window, map errors 67 and 189 ms), so the map's whole history is late and it cannot
    # know the line (its documented limit). Such a run measures the host, not the map, and is
    # measured again, up to three times. Runs that passed beside the same busy loops had
    # 6-7 s of on-time frames there (with 53-56 bins over 50 ms late elsewhere).
    runs = []
    for attempt in range(3):
        r = measure(device_ppm, audio_ppm)
        # Kept for a failed run: its frames replay through the clock map offline.
        trace = r.write_trace(tmp_path / f"frames{attempt}.csv")
        runs.append(r)
        on_time_s = r.on_time_s
        print(f"device {device_ppm:+} ppm, audio {audio_ppm:+} ppm: {r}, on time "
              f"{on_time_s:.2f} s of the window; frames in {trace}")
        if on_time_s >= MIN_ON_TIME_S:
            break
    assert on_time_s >= MIN_ON_TIME_S, \
        f"simavr ran behind its pacing line through the map's window in every run: {runs}"
    assert r.frames > 80 * 20, trace
    assert r.align_error_ms < 1.0, trace
    assert r.force_error_ms < 1.0 and r.audio_error_ms < 1.0, trace
