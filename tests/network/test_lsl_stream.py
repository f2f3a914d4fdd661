"""A 10 s virtual fingertip run over Lab Streaming Layer, recorded by `fingertip record --from
lsl` in another process: every frame, force, event and audio sample arrives with its values."""
from __future__ import annotations

import os
import signal
import time

import pytest

from fingertip.record import schemas as S

from .conftest import start, wait_line
from .test_dds_stream import FORCE_MODEL, by_topic

# LSL finds streams by name anywhere on the machine and has no domains: each test names its
# fingertip after itself and its process, so one test's subscriber never meets another's
# publisher, whichever processes run them at the same time (make test runs the realtime pass
# beside the parallel one).


def unique_name(test: str) -> str:
    return f"{test}_{os.getpid()}"


def decoded(path, name, kind):
    return [S.DECODERS[S.TOPIC_KINDS[kind]](d) for _, d in by_topic(path)[S.topic(name, kind)]]


@pytest.mark.realtime
@pytest.mark.slow
def test_every_message_of_a_10s_run_arrives_over_lsl(tmp_path):
    pytest.importorskip("pylsl")
    local, remote = tmp_path / "local.mcap", tmp_path / "remote.mcap"
    name = unique_name("run10s")
    sub = start("record", "--from", "lsl", "--name", name, "-o", str(remote))
    try:
        wait_line(sub, f"recording {name} from lsl")
        pub = start("publish", "--transport", "lsl", "--virtual", "1", "--name", name,
                    "--virtual-audio", "--force-model", FORCE_MODEL, "--duration", "10",
                    "--record", str(local), "--wait-subscribers", "1", "--wait-timeout", "30")
        _, err = pub.communicate(timeout=60)
        assert pub.returncode == 0, err
        time.sleep(1.0)
    finally:
        sub.send_signal(signal.SIGTERM)
        _, sub_err = sub.communicate(timeout=30)
    assert sub.returncode == 0, sub_err
    raw_a, raw_b = decoded(local, name, "raw"), decoded(remote, name, "raw")
    assert len(raw_a) >= 780 and len(raw_b) == len(raw_a)
    for a, b in zip(raw_a, raw_b, strict=True):
        assert (a.seq, a.device_time_us, a.counts, a.timeout_mask, a.saturation_mask) == \
            (b.seq, b.device_time_us, b.counts, b.timeout_mask, b.saturation_mask)
        # LSL's clock synchronisation on one machine: stamps agree to well under 1 ms.
        assert abs(a.stamp_ns - b.stamp_ns) < 1_000_000
        assert abs((a.arrival_ns - a.stamp_ns) - (b.arrival_ns - b.stamp_ns)) < 1000
    w_a, w_b = decoded(local, name, "wrench"), decoded(remote, name, "wrench")
    assert [w.force for w in w_a] == [w.force for w in w_b] and len(w_a) == len(raw_a)
    e_a, e_b = decoded(local, name, "events"), decoded(remote, name, "events")
    assert [(e.kind, e.value, e.detail) for e in e_a] == [(e.kind, e.value, e.detail)
                                                          for e in e_b]
    # Audio: LSL re-chunks the stream; the samples are the same, none lost.
    au_a, au_b = decoded(local, name, "audio"), decoded(remote, name, "audio")
    assert b"".join(m.data for m in au_a) == b"".join(m.data for m in au_b)
    assert sum(m.frames for m in au_a) >= 9 * 44100
    assert {m.sample_rate for m in au_b} == {44100.0}


@pytest.mark.slow
def test_lsl_streams_declare_the_device_rate_channels_and_information():
    lsl = pytest.importorskip("pylsl")
    import json

    name = unique_name("declare")
    pub = start("publish", "--transport", "lsl", "--virtual", "1", "--name", name,
                "--duration", "20")
    try:
        wait_line(pub, "publishing")
        infos = {}
        for kind in ("raw", "forces", "events"):
            found = lsl.resolve_byprop("name", f"fingertip/{name}/{kind}", 1, 10.0)
            assert found, kind
            infos[kind] = lsl.StreamInlet(found[0]).info(timeout=10.0)
    finally:
        pub.send_signal(signal.SIGINT)
        pub.communicate(timeout=30)
    # The virtual fingertip streams 4 channels at 80 frames/s (its INFO says so).
    assert infos["raw"].nominal_srate() == 80.0 and infos["forces"].nominal_srate() == 80.0
    assert infos["raw"].channel_count() == 4 + 5
    assert infos["events"].nominal_srate() == lsl.IRREGULAR_RATE
    dev = json.loads(infos["raw"].desc().child_value("fingertip"))
    assert dev["name"] == name and dev["info"]["channels"] == 4
