"""FileSource: WAV and FLAC read back bit-exact, chunked like a card, with clear errors."""
from __future__ import annotations

import time

import numpy as np
import pytest
import soundfile as sf

from fingertip.audio import AudioFileError, AudioSource, FileSource
from fingertip.audio.file import read_audio_file

FS = 44100


def pcm(bits: int, channels: int, n: int, seed: int = 0) -> np.ndarray:
    """Random full-range samples, as the dtype a card delivers (24-bit: int32, low byte 0)."""
    rng = np.random.default_rng(seed)
    if bits == 16:
        return rng.integers(-32768, 32768, (n, channels)).astype(np.int16)
    x = rng.integers(-(1 << 23), 1 << 23, (n, channels)).astype(np.int32)
    x[:4] = [[-(1 << 23)], [(1 << 23) - 1], [0], [-1]][:4]  # the extremes
    return (x << 8).astype(np.int32)


@pytest.mark.parametrize("fmt", ["WAV", "FLAC"])
@pytest.mark.parametrize("bits", [16, 24])
@pytest.mark.parametrize("channels", [1, 2])
def test_reads_back_bit_exact_in_blocks(tmp_path, fmt, bits, channels):
    x = pcm(bits, channels, 10_000 + 123, seed=bits + channels)
    path = tmp_path / f"x.{fmt.lower()}"
    sf.write(path, x, FS, format=fmt, subtype=f"PCM_{bits}")
    src = FileSource(path, blocksize=1024, host_time0=50.0)
    assert isinstance(src, AudioSource)
    assert (src.sample_rate, src.channels, src.frames_total) == (FS, channels, len(x))
    assert src.dtype == np.dtype(np.int16 if bits == 16 else np.int32)
    with src:
        chunks = list(src.chunks())
    got = np.concatenate([c.samples for c in chunks])
    np.testing.assert_array_equal(got, x)
    assert [c.frames for c in chunks[:-1]] == [1024] * (len(chunks) - 1)
    assert chunks[-1].frames == len(x) % 1024
    for c in chunks:
        assert c.host_time == 50.0 + c.first_index / FS
        assert c.host_rate == FS and c.lost_before == 0
    assert [c.first_index for c in chunks] == list(range(0, len(x), 1024))
    st = src.stats
    assert (st.frames, st.frames_read, st.overruns_frames, st.timestamp_source) == \
        (len(x), len(x), 0, "ideal")
    assert src.finished and src.read(timeout=0) is None


def test_16_bit_file_as_int32_and_float32_is_exact(tmp_path):
    x = pcm(16, 1, 5000)
    path = tmp_path / "x.wav"
    sf.write(path, x, FS, subtype="PCM_16")
    with FileSource(path, dtype="int32") as src:
        i32 = np.concatenate([c.samples for c in src.chunks()])
    np.testing.assert_array_equal(i32, x.astype(np.int32) << 16)
    with FileSource(path, dtype="float32") as src:
        f32 = np.concatenate([c.samples for c in src.chunks()])
    assert f32.dtype == np.float32
    np.testing.assert_array_equal(f32.astype(np.float64) * 32768, x)


def test_small_reads_split_blocks_without_losing_frames(tmp_path):
    x = pcm(16, 2, 3000)
    path = tmp_path / "x.flac"
    sf.write(path, x, 48000, subtype="PCM_16")
    with FileSource(path, blocksize=512) as src:
        chunks = list(src.chunks(max_frames=100))
    assert max(c.frames for c in chunks) == 100
    np.testing.assert_array_equal(np.concatenate([c.samples for c in chunks]), x)
    assert chunks[0].sample_rate == 48000


@pytest.mark.realtime
def test_realtime_pacing_follows_the_wall_clock(tmp_path):
    x = pcm(16, 1, FS // 4)  # 0.25 s
    path = tmp_path / "x.wav"
    sf.write(path, x, FS)
    src = FileSource(path, blocksize=441, realtime=True)
    t_start = time.monotonic()
    with src:
        chunks = []
        for c in src.chunks(timeout=2.0):
            # A frame is never handed out before its own time has come.
            assert time.monotonic() >= c.time_of(c.end_index - 1) - 1e-3
            chunks.append(c)
    elapsed = time.monotonic() - t_start
    assert 0.24 <= elapsed < 1.0, elapsed
    np.testing.assert_array_equal(np.concatenate([c.samples for c in chunks]), x)
    assert src.host_time0 == pytest.approx(t_start, abs=0.05)
    assert src.stats.overruns_frames == 0


def test_slow_consumer_of_a_paced_file_overruns_counted(tmp_path):
    x = pcm(16, 1, FS // 2)
    path = tmp_path / "x.wav"
    sf.write(path, x, FS)
    src = FileSource(path, blocksize=441, realtime=True, buffer_seconds=0.1)
    with src:
        deadline = time.monotonic() + 3.0
        while not src.finished and time.monotonic() < deadline:
            time.sleep(0.02)
        assert src.stats.overruns_frames > 0  # visible before the consumer reads
        chunks = list(src.chunks(timeout=0))
    lost = sum(c.lost_before for c in chunks)
    assert lost > 0 and lost == src.stats.overruns_frames
    assert sum(c.frames for c in chunks) + lost == len(x)
    assert src.stats.overruns >= 1
    for c in chunks:  # what survives is still exact, at its own index
        np.testing.assert_array_equal(c.samples, x[c.first_index:c.end_index])


def test_missing_directory_corrupt_and_foreign_files(tmp_path):
    with pytest.raises(AudioFileError, match="no such file"):
        FileSource(tmp_path / "nope.wav")
    with pytest.raises(AudioFileError, match="is a directory"):
        FileSource(tmp_path)
    bad = tmp_path / "bad.wav"
    bad.write_bytes(b"RIFF\x10\x00\x00\x00WAVEjunkjunkjunk" + bytes(range(256)))
    with pytest.raises(AudioFileError, match="not a readable WAV or FLAC"):
        FileSource(bad)
    text = tmp_path / "notes.flac"
    text.write_text("not audio at all\n")
    with pytest.raises(AudioFileError, match="not a readable"):
        FileSource(text)
    empty = tmp_path / "empty.wav"
    empty.write_bytes(b"")
    with pytest.raises(AudioFileError):
        FileSource(empty)
    aiff = tmp_path / "x.aiff"
    sf.write(aiff, np.zeros(100, np.int16), FS)
    with pytest.raises(AudioFileError, match="use WAV or FLAC"):
        FileSource(aiff)


def test_truncated_wav_reads_what_is_there(tmp_path):
    x = pcm(16, 1, 4000)
    path = tmp_path / "x.wav"
    sf.write(path, x, FS)
    raw = path.read_bytes()
    path.write_bytes(raw[:-2000])  # a recorder killed mid-write
    with FileSource(path) as src:
        got = np.concatenate([c.samples for c in src.chunks()])
    np.testing.assert_array_equal(got, x[:len(got)])
    assert len(got) == 3000


def test_read_before_start_and_restart(tmp_path):
    path = tmp_path / "x.wav"
    x = pcm(16, 1, 2000)
    sf.write(path, x, FS)
    src = FileSource(path)
    with pytest.raises(RuntimeError, match="never started"):
        src.read()
    for _ in range(2):  # a stopped source starts again from frame 0
        with src:
            got = np.concatenate([c.samples for c in src.chunks()])
        np.testing.assert_array_equal(got, x)


@pytest.mark.realtime
def test_replay_keeps_the_recordings_own_timestamps_and_paces_from_now(tmp_path):
    path = tmp_path / "x.wav"
    sf.write(path, pcm(16, 1, FS // 10), FS)
    src = FileSource(path, blocksize=441, realtime=True, host_time0=12.5)
    t_start = time.monotonic()
    with src:
        chunks = list(src.chunks(timeout=2.0))
    assert time.monotonic() - t_start >= 0.09  # paced from start(), not from 12.5 s
    assert src.stats.late_blocks == 0
    assert chunks[3].host_time == 12.5 + chunks[3].first_index / FS


def test_a_whole_file_read_at_once_matches_and_says_what_a_cut_copy_lacks(tmp_path, caplog):
    x = pcm(16, 2, 4000)
    path = tmp_path / "x.wav"
    sf.write(path, x, FS)
    whole = read_audio_file(path)
    assert whole.rate == FS and whole.missing_frames == 0
    np.testing.assert_array_equal(read_audio_file(path, "int16").samples, x)
    np.testing.assert_array_equal(whole.samples, x / np.float32(32768))
    path.write_bytes(path.read_bytes()[:-4000])  # a recorder killed mid-write
    with caplog.at_level("WARNING"):
        cut = read_audio_file(path)
    assert len(cut.samples) == 3000 and cut.missing_frames == 1000
    assert "cut short" in caplog.text
    aiff = tmp_path / "x.aiff"
    sf.write(aiff, np.zeros(100, np.int16), FS)
    with pytest.raises(AudioFileError, match="use WAV or FLAC"):
        read_audio_file(aiff)
