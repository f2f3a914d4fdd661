"""`publish --material-model`: the classifier's predictions on the microphone go out as
`material` events (and into the local recording), with the audio they were made from."""
from __future__ import annotations

import json
import signal

import numpy as np
import pytest
import soundfile as sf

from fingertip.models.vibration.material import train_material
from fingertip.record import schemas as S
from fingertip.sim.physics import PAPER_SEVEN, Slide, simulate

from .conftest import start, wait_line
from .test_dds_stream import by_topic


def small_model(tmp_path):
    """Two materials, four 1 s slides each: enough for a model that runs, not a good one."""
    root = tmp_path / "data"
    for m in PAPER_SEVEN[:2]:
        (root / m).mkdir(parents=True)
        for k in range(4):
            x = simulate(Slide(m, speed_mm_s=20.0, normal_n=1.0, duration=1.0, seed=k),
                         seed=k).audio.samples.astype(np.float64)
            sf.write(root / m / f"{k}.wav", x, 44100, subtype="PCM_16")
    train_material(root, tmp_path / "model", epochs=30, plot=False)
    return tmp_path / "model" / "material.onnx", list(PAPER_SEVEN[:2])


@pytest.mark.realtime
def test_material_predictions_are_published_as_events(tmp_path):
    model, classes = small_model(tmp_path)
    assert model.exists(), sorted(p.name for p in model.parent.iterdir())
    local, remote = tmp_path / "local.mcap", tmp_path / "remote.mcap"
    sub = start("record", "--from", "dds", "--name", "index", "-o", str(remote))
    try:
        wait_line(sub, "recording index from dds")
        pub = start("publish", "--virtual", "1", "--name", "index", "--virtual-audio",
                    "--material-model", str(model), "--duration", "3", "--record",
                    str(local), "--wait-subscribers", "1")
        _, err = pub.communicate(timeout=60)
        assert pub.returncode == 0, err
    finally:
        sub.send_signal(signal.SIGTERM)
        _, sub_err = sub.communicate(timeout=30)
    events = [S.decode_event(d) for _, d in by_topic(remote)[S.topic("index", "events")]]
    material = [e for e in events if e.kind == "material"]
    assert len(material) >= 10  # about one per classifier step once a window has filled
    for e in material:
        d = json.loads(e.detail)
        assert d["label"] in classes and abs(d["probability"] - e.value) < 1e-3
        assert 0.0 <= e.value <= 1.0
    local_events = [S.decode_event(d) for _, d in by_topic(local)[S.topic("index", "events")]]
    assert [(e.stamp_ns, e.kind, e.detail) for e in local_events if e.kind == "material"] == \
        [(e.stamp_ns, e.kind, e.detail) for e in material]


def test_classifier_without_audio_is_refused(tmp_path):
    p = start("publish", "--virtual", "1", "--material-model", str(tmp_path / "m.onnx"))
    _, err = p.communicate(timeout=60)
    assert p.returncode == 2
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "--virtual-audio" in lines[0]
