"""PNG figures people would rather look at than read: a session summary of force channels,
the piezo spectrogram and the detected events. matplotlib with the Agg backend (no screen)."""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .events import Event
from .outputs import atomic_output


def _spectrogram(x: np.ndarray, fs: float, nfft: int = 1024, hop: int = 256
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Log-power STFT with strided frames and one rfft call (no Python loop per frame)."""
    x = np.asarray(x, dtype=np.float32)
    if x.ndim > 1:
        x = x.mean(axis=1)
    if x.size < nfft:
        x = np.pad(x, (0, nfft - x.size))
    n = 1 + (x.size - nfft) // hop
    frames = np.lib.stride_tricks.as_strided(x, (n, nfft), (x.strides[0] * hop, x.strides[0]))
    spec = np.fft.rfft(frames * np.hanning(nfft).astype(np.float32), axis=1)
    power_db = 10 * np.log10(np.abs(spec) ** 2 + 1e-12)
    times = (np.arange(n) * hop + nfft / 2) / fs
    freqs = np.fft.rfftfreq(nfft, 1 / fs)
    return times, freqs, power_db.T


def session_summary(path: str | Path, *, force_t: np.ndarray, counts: np.ndarray,
                    audio: np.ndarray | None = None, fs: float = 44100.0, audio_t0: float = 0.0,
                    events: Sequence[Event] = (), title: str = "fingertip session",
                    truth: dict[str, Sequence[float]] | None = None,
                    forces: np.ndarray | None = None,
                    labels: Sequence[tuple[float, float, str]] = ()) -> Path:
    """Write a PNG: channel traces, estimated forces (``forces``: (n, 2) newtons, optional)
    with contact intervals, the piezo spectrogram with classified materials (``labels``:
    (start, end, name)), and its RMS envelope with the detected onsets. Times in seconds."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .events import rms_envelope

    path = Path(path)
    rows = (3 if audio is not None else 1) + (forces is not None)
    fig, axes = plt.subplots(rows, 1, figsize=(11, 2.5 * rows + 0.6), sharex=True,
                             squeeze=False)
    ax = axes[0, 0]
    counts = np.atleast_2d(counts)
    for ch in range(counts.shape[1]):
        ax.plot(force_t, counts[:, ch], lw=1, label=f"channel {ch}")
    ax.set_ylabel("counts (tared)")
    ax.legend(loc="upper right", fontsize=7, ncol=5)
    ax.set_title(title)
    row = 1
    if forces is not None:
        ax = axes[row, 0]
        row += 1
        f = np.asarray(forces, dtype=float)
        ax.plot(force_t, f[:, 0], lw=1, label="Fx")
        ax.plot(force_t, f[:, 1], lw=1, label="Fy")
        ax.plot(force_t, np.hypot(f[:, 0], f[:, 1]), lw=1.2, color="k", label="|F|")
        ax.set_ylabel("force (N)")
    makes = [e.time for e in events if e.kind == "contact_make"]
    breaks = [e.time for e in events if e.kind == "contact_break"]
    for i, m in enumerate(makes):
        b = breaks[i] if i < len(breaks) else force_t[-1]
        ax.axvspan(m, b, color="tab:green", alpha=0.12,
                   label="contact (detected)" if i == 0 else None)
    ax.legend(loc="upper right", fontsize=7, ncol=5)
    if audio is not None:
        times, freqs, p = _spectrogram(audio, fs)
        ax = axes[row, 0]
        ax.pcolormesh(times + audio_t0, freqs / 1e3, p, shading="auto", cmap="magma",
                      vmin=np.percentile(p, 5), vmax=np.percentile(p, 99.5))
        ax.set_ylim(0, min(fs / 2e3, 12))
        ax.set_ylabel("piezo kHz")
        top = min(fs / 2e3, 12)
        for t0, t1, name in labels:
            ax.annotate(name.replace("_", " "), ((t0 + t1) / 2, top * 0.92), color="w",
                        ha="center", va="top", fontsize=8,
                        bbox={"fc": "k", "alpha": 0.5, "lw": 0})
        env, rate = rms_envelope(audio, fs)
        ax = axes[row + 1, 0]
        ax.plot(audio_t0 + np.arange(env.size) / rate, env, lw=0.7, color="tab:gray",
                label="piezo RMS (2 ms)")
        onsets = [e.time for e in events if e.kind == "vibration_onset"]
        for j, o in enumerate(onsets):
            ax.axvline(o, color="tab:red", lw=1, label="onset (detected)" if j == 0 else None)
        for j, r in enumerate((truth or {}).get("rims", ())):
            ax.axvline(r, color="tab:blue", lw=1, ls=":",
                       label="cup rim (ground truth)" if j == 0 else None)
        ax.set_yscale("log")
        ax.set_ylabel("RMS (full scale)")
        ax.legend(loc="upper right", fontsize=7)
    axes[-1, 0].set_xlabel("time (s)")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(path) as tmp:
        fig.savefig(tmp, dpi=110, format=Path(path).suffix[1:] or "png")
    plt.close(fig)
    return path
