"""Seeing a MuJoCo run: PNG frames rendered headless (``MUJOCO_GL=egl``) beside the
fingertip's counts, forces and spectrogram, or MuJoCo's passive viewer where a display is.

:func:`render_run` runs one of the live scenes (:data:`.live.SCENES`) for some seconds and
writes ``frames/frame_00000.png ...`` (``fps`` a second), ``counts.csv`` (time, true force on
the fingertip, four counts) and ``summary.png`` (counts, force, spectrogram), like the demo's
summary. Without a display, this package sets ``MUJOCO_GL=egl`` before MuJoCo's first import
(:mod:`._require`), unless the user chose a backend.
"""
from __future__ import annotations

import csv
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

VIEW_HINT = "no display for the viewer: use --render DIR (PNG frames, headless)"


@dataclass
class RenderResult:
    out: Path
    frames: int
    readings: int
    audio_s: float


def render_run(scene: str, out: str | Path, *, seconds: float = 6.0, fps: float = 20.0,
               width: int = 480, height: int = 360, seed: int = 0) -> RenderResult:
    """Run live scene ``scene`` for ``seconds``; frames, counts and a summary in ``out``."""
    from ._require import mujoco
    from .live import LiveSimulation

    mj = mujoco()
    out = Path(out)
    (out / "frames").mkdir(parents=True, exist_ok=True)
    live = LiveSimulation(scene, seed=seed, keep=True)
    renderer = mj.Renderer(live.m, height, width)
    cam = mj.MjvCamera()
    mj.mjv_defaultFreeCamera(live.m, cam)
    cam.distance, cam.elevation, cam.azimuth = 0.3, -12.0, 20.0
    tip = live.sensor.reader.body
    frames = int(seconds * fps)
    try:
        for k in range(frames):
            live.advance_to((k + 1) / fps)
            cam.lookat[:] = live.d.xpos[tip] - (0.0, 0.0, 0.03)  # follow the fingertip
            renderer.update_scene(live.d, cam)
            _save_png(out / "frames" / f"frame_{k:05d}.png", renderer.render())
    finally:
        renderer.close()
    x = live.audio_so_far()
    fs = live.sensor.piezo.fs
    _write_csv(out / "counts.csv", live.history)
    _summary(out / "summary.png", live.history, x, fs, scene)
    return RenderResult(out, frames, len(live.history), len(x) / fs)


def _save_png(path: Path, rgb: np.ndarray) -> None:
    import matplotlib.image

    matplotlib.image.imsave(path, rgb)


def _write_csv(path: Path, readings: list) -> None:
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["t_s", "fx_n", "fy_n", "fz_n", "height_mm", "c0", "c1", "c2", "c3"])
        for r in readings:
            w.writerow([f"{r.t:.4f}", *(f"{v:.5f}" for v in r.force_n), f"{r.height_mm:.3f}",
                        *(int(c) for c in r.counts)])


def _summary(path: Path, readings: list, x: np.ndarray, fs: int, scene: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.array([r.t for r in readings])
    c = np.array([r.counts for r in readings], float)
    f = np.array([r.force_n for r in readings])
    fig, ax = plt.subplots(3, 1, figsize=(9, 8), sharex=True)
    if len(t):
        for i in range(4):
            ax[0].plot(t, c[:, i] - c[0, i], lw=0.8, label=f"channel {i}")
        ax[1].plot(t, np.linalg.norm(f, axis=1), color="k", lw=0.9)
    ax[0].set_ylabel("counts - first")
    ax[0].legend(fontsize=7, ncol=4)
    ax[1].set_ylabel("|force| on the fingertip (N)")
    if len(x) > 512:
        ax[2].specgram(x, NFFT=512, Fs=fs, noverlap=256, cmap="magma")
    ax[2].set_ylabel("piezo (Hz)")
    ax[2].set_xlabel("simulated time (s)")
    fig.suptitle(f"MuJoCo scene {scene!r}: one fingertip")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def view(scene: str, seconds: float | None = None, seed: int = 0) -> None:
    """MuJoCo's passive viewer on a live scene, in real time (needs a display)."""
    if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
        raise RuntimeError(VIEW_HINT)
    import time

    import mujoco.viewer

    from .live import LiveSimulation

    live = LiveSimulation(scene, seed=seed)
    with mujoco.viewer.launch_passive(live.m, live.d) as v:
        w0 = time.monotonic()
        while v.is_running() and (seconds is None or live.d.time < seconds):
            live.advance_to(time.monotonic() - w0)
            v.sync()
            time.sleep(0.01)
