"""Fixtures of the recording suite: a virtual fingertip on a pty, recordings made from it."""
from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

from fingertip import Fingertip, Frame
from fingertip.audio import Chunk, SimulatedSource
from fingertip.record import Recorder, RecorderStats
from fingertip.sim import VirtualFirmware
from fingertip.sim.device.pty_device import PtyDevice

RATE = 80  # frames per second of the virtual fingertip


def counts_source(t_us: int) -> tuple[int, int, int, int]:
    """Channel inputs that change every frame (so frames are distinguishable)."""
    k = t_us // 12500
    return (1000 + k % 97, -50_000 + 3 * (k % 11), 0x7FFFFF, 5 - k % 3)


def force_model(counts):
    """A stand-in force model: counts -> (fx, fy) in newtons."""
    return (counts[0] * 1e-3, counts[1] * 1e-4)


def tone(t: np.ndarray) -> np.ndarray:
    return 0.25 * np.sin(2 * np.pi * 440.0 * t) + 0.1 * np.sin(2 * np.pi * 1234.5 * t)


@pytest.fixture
def device(tmp_path) -> Iterator[PtyDevice]:
    fw = VirtualFirmware(4, source=counts_source)
    with PtyDevice(fw, link=tmp_path / "ttyFT0") as dev:
        yield dev


@dataclass
class Session:
    """What a live session handed to user code, to compare recordings and replays with."""

    path: Path
    frames: list[Frame] = field(default_factory=list)
    chunks: list[Chunk] = field(default_factory=list)
    stats: RecorderStats | None = None
    name: str = "index"


def record_session(port: str, path: Path, seconds: float = 1.5, *, audio: bool = True,
                   model=force_model, name: str = "index", **kw) -> Session:
    """Record a live session from the pty device; keep what the live code saw."""
    s = Session(path, name=name)
    rec = Recorder(path, **kw).start()
    with Fingertip(port) as ft:
        ft.add_callback(s.frames.append)
        rec.attach(ft, name, force_model=model)
        src = None
        if audio:
            src = SimulatedSource(tone, 44100, dtype="int16", blocksize=441)
            src.start()
        rec.write_event(name, "marker", 1.5, detail="hello")
        ft.start()
        t_end = time.monotonic() + seconds
        while time.monotonic() < t_end:
            if src is not None:
                c = src.read(timeout=0.02)
                if c is not None:
                    c = Chunk(c.samples.copy(), c.first_index, c.sample_rate, c.host_time,
                              c.host_rate, c.lost_before)
                    s.chunks.append(c)
                    rec.write_audio(name, c)
            else:
                time.sleep(0.02)
        ft.stop()
        if src is not None:
            src.stop()
        time.sleep(0.05)
        ft.remove_callback(s.frames.append)
    s.stats = rec.close()
    return s


@pytest.fixture(scope="session")
def session(tmp_path_factory) -> Session:
    """One recorded live session (1.5 s: frames, forces, audio, an event), shared: read it,
    do not change it."""
    d = tmp_path_factory.mktemp("session")
    with PtyDevice(VirtualFirmware(4, source=counts_source), link=d / "ttyFT0") as dev:
        return record_session(str(dev.link), d / "run.mcap")
