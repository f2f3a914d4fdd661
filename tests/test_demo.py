"""`fingertip demo`, as `make demo` runs it: the real firmware in simavr, the bridge, events,
and the PNG summary; the detected events agree with the scene's ground truth."""
from __future__ import annotations

import pytest

from fingertip.demo import demo_scene, rim_truth, run_demo


@pytest.mark.slow
@pytest.mark.usefixtures("fil_builds")
def test_demo_on_the_firmware(tmp_path):
    r = run_demo(tmp_path, use_firmware=True, live=False)
    assert r.png.exists() and r.png.stat().st_size > 50_000
    assert r.stats["frames_lost"] == 0 and r.stats["crc_errors"] == 0
    assert r.stats["frames"] > 80 * 12 * 0.95
    assert r.stats["audio_overflows"] == 0
    # The recording holds the frames, the audio and the events, and replays as a device.
    from fingertip.record import Recording, Replay

    rec = Recording(r.recording)
    assert rec.complete and r.stats["recording_dropped"] == 0
    topics = set(rec.channels())
    assert {"/fingertip/index/raw", "/fingertip/index/audio",
            "/fingertip/index/events"} <= topics
    with Replay(r.recording, speed=None) as rp:
        rp.start()
        assert len(list(rp.frames(timeout=2.0))) >= len(r.frames) - 5
    makes = [e.time for e in r.events if e.kind == "contact_make"]
    breaks = [e.time for e in r.events if e.kind == "contact_break"]
    assert len(makes) == len(breaks) == 4  # a press, two slides, the cup slide
    press = demo_scene().parts[0]
    assert abs(makes[0] - press.pre_s) < 0.1
    # Calibrated forces in newtons: the press peaks near its 2 N, the slides press ~1 N.
    import numpy as np

    mag = np.hypot(r.forces[:, 0], r.forces[:, 1])
    assert 1.6 < mag.max() < 2.6 and np.median(mag[:20]) < 0.15
    assert [m for _, _, m in r.materials][:1] == ["coarse_fabric"]
    onsets = [e.time for e in r.events if e.kind == "vibration_onset"]
    rims = rim_truth(demo_scene())["rims"]
    for rim in rims:
        assert min(abs(o - rim) for o in onsets) < 0.02, (rim, onsets)
