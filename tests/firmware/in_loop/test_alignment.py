"""Force and audio aligned to within 1 ms with +-100 ppm clock errors and a known offset."""
from __future__ import annotations

import pytest

from tests.firmware.in_loop.alignment import measure


@pytest.mark.realtime
@pytest.mark.slow
@pytest.mark.usefixtures("fil_builds")
@pytest.mark.parametrize("device_ppm, audio_ppm", [(100.0, -100.0), (-100.0, 100.0)])
def test_force_and_audio_align_within_1ms(device_ppm, audio_ppm):
    # The truth is simavr's pacing line: a device that sends late but keeps its crystal. On
    # a starved host simavr itself runs behind that line for seconds (busy series 17: 1846
    # frames of 2000 in 25 s), which is not a clock error any map could see; such a run
    # measures the host, so it is measured again (up to three times), and fails if it never
    # kept pace.
    runs = []
    for _ in range(3):
        r = measure(device_ppm, audio_ppm)
        runs.append(r)
        print(f"device {device_ppm:+} ppm, audio {audio_ppm:+} ppm: {r}")
        if r.device_kept_pace:
            break
    assert r.device_kept_pace, f"simavr ran behind its pacing line in every run: {runs}"
    assert r.frames > 80 * 20
    assert r.align_error_ms < 1.0
    assert r.force_error_ms < 1.0 and r.audio_error_ms < 1.0
