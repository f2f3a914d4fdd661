"""The check's piezo step through a real audio stack: taps rendered by the virtual unit are
played into a PulseAudio null sink and recorded by the check's sound-card capture
(`fingertip.check.audio_capture.SoundCardAudio`), then judged by `check_piezo`."""
from __future__ import annotations

import time
from types import SimpleNamespace

import numpy as np
import pytest
import soundfile as sf

from fingertip.check.audio_capture import SoundCardAudio
from fingertip.check.piezo import check_piezo
from fingertip.sim.device.bringup import VirtualUnit

pytestmark = pytest.mark.slow
FS = 44100


@pytest.mark.realtime
@pytest.mark.parametrize("faults,expect", [((), "pass"), (("piezo-humming",), "fail")])
def test_card_capture_of_taps(pulse_server, tmp_path, faults, expect):
    from fingertip.sim.device.faults import parse_faults

    unit = VirtualUnit(2, parse_faults(list(faults)))
    unit.scene.tap([0.6, 0.95, 1.3])
    x = unit.render_audio(0.0, 2.0)
    path = tmp_path / "taps.wav"
    sf.write(path, np.clip(x, -1, 1 - 2 ** -15), FS, subtype="PCM_16")
    audio = SoundCardAudio("pulse", SimpleNamespace(host_minus_device_s=0.0), FS)
    audio.start(0.0)
    time.sleep(0.3)
    t_play = time.monotonic()
    player = pulse_server.play(path)
    player.wait(timeout=20)
    time.sleep(0.5)
    y, t0 = audio.stop(0.0)
    assert audio.sample_rate == FS and len(y) > 1.5 * FS
    # The taps, in the card's clock: the file's tap times after the player started.
    taps = [t_play + t for t in (0.6, 0.95, 1.3)]
    res = {r.check: r for r in check_piezo(y, FS, t0, taps, 3, audio.name)}
    assert res["piezo hears taps"].status == "pass", res["piezo hears taps"].value
    assert res["piezo hum"].status == expect, res["piezo hum"].value
    # Stamps of the card against the player's launch: within the null sink's render-ahead.
    assert abs(res["tap delay sound - force"].data["seconds"]) < 0.5
