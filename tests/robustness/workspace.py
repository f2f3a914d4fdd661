"""The files, ports and servers the bad-input cases run against, made once per session.

:func:`build` writes good inputs (a recording, a WAV, a trained material model, a
calibration dataset) and bad ones (empty, random bytes, cut short, the wrong kind, silent,
constant, NaN, clipped, a FIFO) into one folder, and starts a virtual fingertip on a pty.
Paths are looked up by name (``ws["fifo"]``); ``{name}`` in a case's arguments is replaced by
that path.
"""
from __future__ import annotations

import contextlib
import io
import os
import socket
import threading
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import soundfile as sf

from fingertip.record import Recording
from fingertip.reference.rdt import RECORD


def _wav(path: Path, x: np.ndarray, rate: int = 44100, subtype: str | None = None) -> Path:
    sf.write(path, x, rate, subtype=subtype)
    return path


@dataclass
class Workspace:
    root: Path
    paths: dict[str, Path] = field(default_factory=dict)
    stack: contextlib.ExitStack = field(default_factory=contextlib.ExitStack)

    def __getitem__(self, name: str) -> Path:
        return self.paths[name]

    def fmt(self, text: str) -> str:
        """``{name}`` -> the path of ``name``; ``{tmp}``: a fresh folder of the case."""
        return text.format(**{k: str(v) for k, v in self.paths.items()})

    def close(self) -> None:
        self.stack.close()


class RdtServer:
    """A UDP server on 127.0.0.1 that answers an RDT start with ``count`` packets made by
    ``packet(i)`` (wrong sizes, status bits: what the client must explain)."""

    def __init__(self, packet, count: int = 2000) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.2)
        self.port = self.sock.getsockname()[1]
        self.packet, self.count = packet, count
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while not self.stop.is_set():
            try:
                data, addr = self.sock.recvfrom(64)
            except OSError:
                continue
            if data[2:4] == b"\x00\x02":  # start streaming
                for i in range(self.count):
                    self.sock.sendto(self.packet(i), addr)

    def close(self) -> None:
        self.stop.set()
        self.thread.join(2)
        self.sock.close()


def build(root: Path, *, model: bool = True) -> Workspace:
    """Everything the cases need under ``root`` (a virtual fingertip keeps running until
    :meth:`Workspace.close`)."""
    with contextlib.redirect_stdout(io.StringIO()):  # the set-up's own reports
        return _build(root, model)


def _build(root: Path, model: bool) -> Workspace:
    from fingertip.cli import main
    from fingertip.sim import VirtualFirmware
    from fingertip.sim.physics import Idle, VirtualStrainSensor
    from fingertip.sim.device.pty_device import PtyDevice

    root.mkdir(parents=True, exist_ok=True)
    ws = Workspace(root)
    p = ws.paths
    p["root"] = root
    rng = np.random.default_rng(28)
    source = VirtualStrainSensor(0).as_source(Idle(duration=1e9))
    dev = ws.stack.enter_context(PtyDevice(VirtualFirmware(4, source=source),
                                           link=root / "ttyFT"))
    p["port"] = Path(dev.link)
    p["noport"] = root / "no-such-port"

    noise = rng.normal(0, 0.1, 44100).astype(np.float32)
    p["good_wav"] = _wav(root / "good.wav", noise)
    p["silent_wav"] = _wav(root / "silent.wav", np.zeros(44100, np.int16))
    p["const_wav"] = _wav(root / "const.wav", np.full(44100, 1000, np.int16))
    nan = noise.copy()
    nan[100:200] = np.nan
    p["nan_wav"] = _wav(root / "nan.wav", nan, subtype="FLOAT")
    inf = noise.copy()
    inf[5] = np.inf
    p["inf_wav"] = _wav(root / "inf.wav", inf, subtype="FLOAT")
    p["clip_wav"] = _wav(root / "clip.wav", np.clip(noise * 30, -1, 1))
    p["cut_wav"] = root / "cut.wav"
    p["cut_wav"].write_bytes(p["good_wav"].read_bytes()[:60])
    p["empty"] = root / "empty.bin"
    p["empty"].write_bytes(b"")
    p["random"] = root / "random.bin"
    p["random"].write_bytes(rng.bytes(5000))
    p["text"] = root / "notes.txt"
    p["text"].write_text("not what you think\n")
    p["folder"] = root / "a-folder"
    p["folder"].mkdir()
    (p["folder"] / "inside.txt").write_text("x")
    p["empty_folder"] = root / "empty-folder"
    p["empty_folder"].mkdir()
    p["missing"] = root / "missing.file"
    p["nodir"] = root / "no" / "such" / "dir"
    p["fifo"] = root / "fifo"
    os.mkfifo(p["fifo"])
    p["latin"] = root / "latin1.csv"
    p["latin"].write_bytes("ch0;ch1\n\xe9\xe8\n".encode("latin-1"))

    # A good recording (1 s of the virtual fingertip with the WAV as its microphone).
    p["rec"] = root / "good.mcap"
    code = main(["record", "--port", str(dev.link), "-o", str(p["rec"]), "--duration", "1",
                 "--audio-file", str(p["good_wav"]), "--name", "index"])
    assert code == 0, "the workspace's recording failed"
    data = p["rec"].read_bytes()
    p["cut_rec"] = root / "cut.mcap"
    cut = _cut_after_a_frame(data, p["cut_rec"])
    p["head_rec"] = root / "head.mcap"
    p["head_rec"].write_bytes(data[:8])
    p["magic_rnd"] = root / "magic-random.mcap"
    p["magic_rnd"].write_bytes(data[:8] + rng.bytes(4000))
    p["part_rec"] = root / ".run.mcap.part"
    p["part_rec"].write_bytes(data[:cut])

    # Vibration folders: good (sim), silent, clipped, one class, empty classes.
    p["vib"] = root / "vib"
    assert main(["sim", "dataset", "vibration", str(p["vib"]), "--recordings-per-class", "3",
                 "--seconds", "0.5", "-q"]) == 0
    for name, x in (("zeros", np.zeros(8000)), ("clipped", np.clip(noise[:8000] * 30, -1, 1)),
                    ("dc", np.full(8000, 0.2))):
        f = root / f"vib_{name}"
        for c in ("a", "b"):
            (f / c).mkdir(parents=True)
            for k in range(3):
                _wav(f / c / f"{k}.wav", x, 8000, "FLOAT")
        p[f"vib_{name}"] = f
    one = root / "vib_one"
    (one / "a").mkdir(parents=True)
    _wav(one / "a" / "x.wav", noise[:8000], 8000)
    p["vib_one"] = one
    if model:
        p["model_dir"] = root / "model"
        assert main(["train", "material", str(p["vib"]), "-o", str(p["model_dir"]),
                     "--models", "baseline", "--augment", "0", "--json"]) == 0
        p["model"] = p["model_dir"] / "material.onnx"
    p["fake_onnx"] = root / "fake.onnx"
    p["fake_onnx"].write_bytes(rng.bytes(300))

    # Calibration data: a simulated sweep, and damaged copies.
    p["cal"] = root / "cal"
    assert main(["sim", "dataset", "calibration", str(p["cal"]), "-q"]) == 0
    csv = (p["cal"] / "unit_0.csv").read_text()
    p["cal_cut"] = root / "cal_cut.csv"
    p["cal_cut"].write_text(csv[: len(csv) // 3].rsplit("\n", 1)[0][:-3])
    p["cal_header"] = root / "cal_header.csv"
    p["cal_header"].write_text(csv.split("\n", 1)[0] + "\n")
    p["toml_bad"] = root / "bad.toml"
    p["toml_bad"].write_text("[physics\nx = = 1\n")

    # Reference sensors that answer wrongly.
    for name, packet in (("rdt_size", lambda i: b"x" * 20),
                         ("rdt_status", lambda i: RECORD.pack(i, i, 1, 0, 0, 0, 0, 0, 0))):
        srv = RdtServer(packet)
        ws.stack.callback(srv.close)
        p[name] = Path(f"127.0.0.1:{srv.port}")
    return ws


def _cut_after_a_frame(data: bytes, path: Path) -> int:
    """Write ``data`` cut short to ``path``: at half its bytes, or later if the first half
    holds no fingertip frame (a busy machine's recording can begin with audio alone); the
    commands are then meant to keep what the cut file holds. Returns the length."""
    step = max(len(data) // 16, 1)
    for cut in range(len(data) // 2, len(data) - 1, step):
        path.write_bytes(data[:cut])
        if next(Recording(path).records(kinds=["raw"]), None) is not None:
            return cut
    raise AssertionError("the workspace's recording holds no fingertip frame before its end")
