"""Recordings as a source: WAV and FLAC through soundfile (libsndfile), chunked like a card."""
from __future__ import annotations

import logging
import os
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import soundfile as sf

from .blocks import BlockSource
from .source import AudioFileError

log = logging.getLogger(__name__)

FORMATS = ("WAV", "WAVEX", "RF64", "W64", "FLAC")
"""Containers accepted (what libsndfile calls them)."""

_DEFAULT_DTYPE = {"PCM_16": "int16", "PCM_S8": "int16", "PCM_U8": "int16",
                  "PCM_24": "int32", "PCM_32": "int32", "FLOAT": "float32",
                  "DOUBLE": "float32"}


def _file_info(path: Path) -> sf._SoundFileInfo:
    if not path.exists():
        raise AudioFileError(f"{path}: no such file")
    if path.is_dir():
        raise AudioFileError(f"{path}: is a directory, not a WAV or FLAC file")
    try:
        info = sf.info(str(path))
    except (sf.SoundFileError, RuntimeError, ValueError) as e:
        raise AudioFileError(f"{path}: not a readable WAV or FLAC file ({e})") from e
    if info.format not in FORMATS:
        raise AudioFileError(f"{path}: {info.format_info or info.format} is not supported; "
                             "use WAV or FLAC")
    if info.samplerate <= 0 or info.channels <= 0:
        raise AudioFileError(f"{path}: bad header ({info.samplerate} Hz, "
                             f"{info.channels} channels)")
    return info


@dataclass(frozen=True)
class AudioFile:
    """A whole recording read at once (:func:`read_audio_file`)."""

    samples: np.ndarray
    """(frames, channels), the dtype asked for."""
    rate: int
    missing_frames: int = 0
    """Frames the WAV header announces beyond those the file holds (a copy cut short)."""


def read_audio_file(path: str | os.PathLike, dtype: str = "float32") -> AudioFile:
    """All frames of a WAV or FLAC file (float32: 1.0 = full scale), or a one-line
    :class:`AudioFileError`. A WAV cut short is read up to its end, with a warning and
    ``missing_frames`` set."""
    path = Path(path)
    _file_info(path)
    try:
        data, fs = sf.read(str(path), dtype=dtype, always_2d=True)
    except (sf.SoundFileError, RuntimeError, ValueError) as e:
        raise AudioFileError(f"{path}: not a readable WAV or FLAC file ({e})") from e
    announced = wav_announced_frames(path)
    missing = announced - len(data) if announced is not None and announced > len(data) else 0
    if missing:
        # libsndfile reads what is there; say that the end is missing.
        log.warning("%s is cut short: its header announces %d frames, it holds %d "
                    "(using those)", path, announced, len(data))
    return AudioFile(data, int(fs), missing)


def wav_announced_frames(path: Path) -> int | None:
    """Frames a RIFF/WAVE file's header announces (its data chunk's size over its frame
    size), or None when it is not such a file or says nothing usable."""
    try:
        with open(path, "rb") as f:
            head = f.read(12)
            if len(head) < 12 or head[:4] != b"RIFF" or head[8:12] != b"WAVE":
                return None
            block = None
            while True:
                h = f.read(8)
                if len(h) < 8:
                    return None
                cid, size = h[:4], struct.unpack("<I", h[4:])[0]
                if cid == b"fmt ":
                    fmt = f.read(size + (size & 1))
                    block = struct.unpack("<H", fmt[12:14])[0] if len(fmt) >= 14 else None
                    continue
                if cid == b"data":
                    # 0 and 0xFFFFFFFF are what streaming writers leave: no length known
                    if not block or size in (0, 0xFFFFFFFF):
                        return None
                    return size // block
                f.seek(size + (size & 1), 1)
    except OSError:
        return None


class FileSource(BlockSource):
    """Frames of a WAV or FLAC file, in blocks of ``blocksize``, sample-exact.

    ``dtype`` None picks the file's own: int16 for 16-bit, int32 for 24/32-bit (24-bit
    samples left-aligned, low byte zero, like a 24-bit card), float32 for float files.
    Integer files read as another integer dtype are shifted exactly (16-bit as int32:
    ``x << 16``); as float32: ``x / 2**15`` (exact). ``realtime``: pace like a live card.
    ``host_time0``: the host time of frame 0 (default: when started).
    """

    def __init__(self, path: str | os.PathLike, *, dtype: str | None = None,
                 blocksize: int = 1024, realtime: bool = False, buffer_seconds: float = 10.0,
                 host_time0: float | None = None) -> None:
        self.path = Path(path)
        info = _file_info(self.path)
        self.info = info
        self.frames_total = int(info.frames)
        self.subtype = info.subtype
        dtype = dtype or _DEFAULT_DTYPE.get(info.subtype, "float32")
        super().__init__(info.samplerate, info.channels, dtype, blocksize=blocksize,
                         realtime=realtime,
                         buffer_seconds=max(buffer_seconds, 2 * blocksize / info.samplerate),
                         name=str(self.path), host_time0=host_time0)
        self._file: sf.SoundFile | None = None
        self._buf = np.zeros((self.blocksize, self.channels), dtype=self.dtype)

    def _open(self) -> None:
        self._close()
        try:
            self._file = sf.SoundFile(str(self.path))
        except (sf.SoundFileError, RuntimeError, OSError) as e:
            raise AudioFileError(f"{self.path}: cannot open ({e})") from e

    def _close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None

    def _next_block(self, first_index: int, n: int) -> np.ndarray | None:
        f = self._file
        if f is None:
            return None
        try:
            got = f.read(frames=n, out=self._buf[:n])
        except (sf.SoundFileError, RuntimeError) as e:
            raise AudioFileError(f"{self.path}: read failed at frame {first_index} ({e})"
                                 ) from e
        return got
