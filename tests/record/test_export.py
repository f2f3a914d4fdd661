"""Export: CSV per fingertip, WAV per audio stream (original format), events CSV."""
from __future__ import annotations

import csv

import numpy as np
import pytest
import soundfile as sf

from fingertip import Frame
from fingertip.audio import Chunk, FileSource
from fingertip.record import ExportError, Recorder, RecordingError, export


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_csv_wav_and_events(session, tmp_path):
    out = tmp_path / "out"
    res = export(session.path, out)
    assert {p.name for p in res.files} == {"index.csv", "index_audio.wav",
                                          "index_audio_chunks.csv", "events.csv"}
    rows = read_csv(out / "index.csv")
    frames = session.frames
    assert len(rows) == len(frames) == res.frames["index"]
    assert list(rows[0]) == ["unix_time", "host_time", "device_time_us", "seq",
                             "arrival_time", "ch0", "ch1", "ch2", "ch3", "timeout_mask",
                             "saturation_mask", "fx", "fy", "fz", "tx", "ty", "tz"]
    for r, f in zip(rows, frames, strict=True):
        assert (int(r["seq"]), int(r["device_time_us"])) == (f.seq, f.device_time_us)
        assert tuple(int(r[f"ch{i}"]) for i in range(4)) == f.counts
        assert (int(r["timeout_mask"]), int(r["saturation_mask"])) == \
            (f.timeout_mask, f.saturation_mask)
        assert float(r["host_time"]) == pytest.approx(f.host_time, abs=2e-9)
        assert float(r["fx"]) == pytest.approx(f.counts[0] * 1e-3)
        assert float(r["fy"]) == pytest.approx(f.counts[1] * 1e-4)
    x, fs = sf.read(out / "index_audio.wav", dtype="int16", always_2d=True)
    info = sf.info(str(out / "index_audio.wav"))
    assert (fs, info.subtype, info.channels) == (44100, "PCM_16", 1)
    np.testing.assert_array_equal(x, np.concatenate([c.samples for c in session.chunks]))
    chunks = read_csv(out / "index_audio_chunks.csv")
    assert len(chunks) == len(session.chunks)
    assert float(chunks[3]["host_time"]) == pytest.approx(session.chunks[3].host_time,
                                                         abs=2e-9)
    ev = read_csv(out / "events.csv")
    assert [(e["fingertip"], e["kind"], float(e["value"]), e["detail"]) for e in ev] == \
        [("index", "marker", 1.5, "hello")]
    assert not res.truncated and res.unmatched_wrenches == 0


def test_24_bit_audio_keeps_its_format_and_gaps_are_zero_filled(tmp_path):
    rng = np.random.default_rng(1)
    x = (rng.integers(-(1 << 23), 1 << 23, (3000, 2)).astype(np.int32) << 8)
    wav = tmp_path / "in.wav"
    sf.write(wav, x, 48000, subtype="PCM_24")
    src = FileSource(wav, blocksize=1000, host_time0=5.0)
    path = tmp_path / "rec.mcap"
    with Recorder(path) as rec:
        rec.record_audio(src, "thumb").join(5)
        # A lost stretch: 500 frames missing before the next chunk.
        rec.write_audio("thumb", Chunk(x[:100], 3500, 48000.0, 5.0 + 3500 / 48000, 48000.0,
                                       lost_before=500))
        rec.write_frame("thumb", Frame(1, 0, 5.0, 5.0, (1, 2)))
    res = export(path, tmp_path / "o")
    y, fs = sf.read(tmp_path / "o" / "thumb_audio.wav", dtype="int32", always_2d=True)
    assert fs == 48000 and sf.info(str(tmp_path / "o" / "thumb_audio.wav")).subtype == "PCM_24"
    np.testing.assert_array_equal(y[:3000], x)
    assert not y[3000:3500].any()
    np.testing.assert_array_equal(y[3500:], x[:100])
    assert res.audio_gap_frames == {"thumb": 500} and res.audio_frames == {"thumb": 3100}
    rows = read_csv(tmp_path / "o" / "thumb.csv")
    assert "fx" not in rows[0] and rows[0]["ch1"] == "2"


def test_float_audio_and_a_truncated_file(session, tmp_path):
    path = tmp_path / "f.mcap"
    a = np.linspace(-1, 1, 200, dtype=np.float32).reshape(100, 2)
    with Recorder(path) as rec:
        rec.write_audio("index", Chunk(a, 0, 8000.0, 1.0, 8000.0))
    export(path, tmp_path / "o")
    y, fs = sf.read(tmp_path / "o" / "index_audio.wav", dtype="float32", always_2d=True)
    assert sf.info(str(tmp_path / "o" / "index_audio.wav")).subtype == "FLOAT"
    np.testing.assert_array_equal(y, a)
    data = session.path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[:len(data) // 2])
    res = export(cut, tmp_path / "c")
    assert res.truncated and 0 < res.frames["index"] < len(session.frames)


def test_export_errors(session, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(ExportError, match="cannot write into"):
        export(session.path, blocker / "sub")
    with pytest.raises(RecordingError, match="no such file"):
        export(tmp_path / "missing.mcap", tmp_path / "o")
