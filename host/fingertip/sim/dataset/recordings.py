"""Vibration datasets: labelled recordings of simulated scenes (materials, box shakes, cup
slides) as WAV or FLAC, one folder per class, a manifest and the cups' truth files."""
from __future__ import annotations

import csv
import dataclasses
import json
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from ... import __version__
from ...audio.pcm import to_float, to_pcm
from ..physics import (
    BOX_CONTENTS,
    PAPER_SEVEN,
    AudioChain,
    BoxShake,
    CupStackSlide,
    Scene,
    Slide,
    simulate,
)
from ..physics.vibration import good_fft_size
from .output import (
    GENERATOR,
    DatasetError,
    DatasetResult,
    Progress,
    check_int,
    derived_seed,
    load_params_file,
    write_meta,
    params_sha256,
    prepare_output,
)

MANIFEST_FILE = "manifest.csv"

KINDS = ("materials", "shake", "cups")
DEFAULT_RECORDINGS = {"materials": 20, "shake": 20, "cups": 36}
"""The paper: 20 shake recordings per class, 36 cup-counting trials (materials: ours)."""
TASK_BOX_ITEMS = {"screws": (5, 12), "rubber_bands": (6, 14), "empty": (0, 0)}
"""Items per box in the shake-and-pick scene (inclusive; sim/world/boxes draws from these)."""
TASK_AMPLITUDE_GAIN = (0.8, 1.05)
"""The simulated arm's real shake amplitude over the commanded one in that scene."""
TASK_PREAMP_GAIN = (0.6, 1.5)
"""The microphone's gain per trial in that scene, over the parameter file's preamp gain."""
TASK_MAINS_HZ = (50.0, 60.0)
"""The mains frequency a trial of that scene picks up (one of these)."""
MIN_RATE_HZ, MAX_RATE_HZ = 1000, 192_000
FORMATS = ("wav", "flac")

MANIFEST_COLUMNS = ("file", "class", "seed", "duration_s", "rate_hz", "frames", "speed_mm_s",
                    "normal_n", "clipped_fraction", "rms_dbfs", "params")


def resample(x: np.ndarray, fs_in: int, fs_out: int) -> np.ndarray:
    """Band-limited resampling (one FFT over the whole recording, brick-wall at the lower
    Nyquist frequency, as a sound card's own decimation filter would be, near enough).

    The ends are extended by reflection (0.05 s or more) so that the FFT's wrap-around does
    not leak one end into the other. Output length: round(len(x) * fs_out / fs_in).
    """
    x = np.asarray(x, dtype=np.float64)
    if fs_in == fs_out:
        return x.copy()
    ratio = Fraction(int(fs_out), int(fs_in))
    p, q = ratio.numerator, ratio.denominator
    n = len(x)
    m = (n * p + q // 2) // q
    if n < 2:
        return np.zeros(m) + (x[0] if n else 0.0)
    pad = q * math.ceil(0.05 * fs_in / q)
    blocks = good_fft_size(math.ceil((n + 2 * pad) / q))
    total = blocks * q
    xp = np.pad(x, (pad, total - n - pad), mode="reflect", reflect_type="odd")
    m_total = blocks * p
    spec = np.fft.rfft(xp)
    keep = min(len(spec), m_total // 2 + 1)
    out_spec = np.zeros(m_total // 2 + 1, dtype=complex)
    out_spec[:keep] = spec[:keep]
    if keep == m_total // 2 + 1 and m_total % 2 == 0:
        out_spec[-1] = 0.0  # the new Nyquist bin: ambiguous phase, drop it
    if p < q:  # downsampling: a short taper over the top 2 % of the band (less ringing)
        k = max(1, keep // 50)
        out_spec[keep - k:keep] *= 0.5 + 0.5 * np.cos(np.linspace(0, np.pi, k))
    y = np.fft.irfft(out_spec, m_total) * (m_total / total)
    off = pad * p // q
    return y[off:off + m]


@dataclass(frozen=True)
class _Plan:
    cls: str
    index: int
    seed: int
    scene: Scene

    @property
    def stem(self) -> str:
        return f"{self.cls}/{self.cls}_{self.index:04d}"


def _log_uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def plan_vibration(kind: str, recordings_per_class: int, seconds: float | None,
                   seed: int, *, task_variation: bool = False) -> list[_Plan]:
    """The recordings :func:`write_vibration` makes, with their scenes (nothing simulated).

    Per recording (uniform or log-uniform draws from the recording's own seed):

    - materials: the paper's seven, sliding at 10-40 mm/s (log-uniform) with 0.5-2 N
      (log-uniform) for ``seconds`` (default: the paper's 16 mm slide at that speed);
    - shake: screws / rubber_bands / empty, 0.67 Hz, 5 cm, ``seconds`` (default 5.6 s),
      grip 1.0-2.0 N; with ``task_variation`` also the shake-and-pick scene's own variation:
      the box's fill (:data:`TASK_BOX_ITEMS`) and the arm's real amplitude
      (:data:`TASK_AMPLITUDE_GAIN` x 5 cm), drawn after the grip so that the other draws
      stay as they are;
    - cups: five cups, 21 mm slide at 5-20 mm/s, 0.3-0.6 N, starting at a robot Z of
      100-140 mm (``seconds`` does not apply).
    """
    if kind not in KINDS:
        raise DatasetError(f"kind must be one of {', '.join(KINDS)}, not {kind!r}")
    classes = {"materials": PAPER_SEVEN, "shake": BOX_CONTENTS, "cups": ("cups",)}[kind]
    kind_tag = KINDS.index(kind)
    plans = []
    for ci, cls in enumerate(classes):
        for k in range(recordings_per_class):
            rs = derived_seed(seed, kind_tag, ci, k)
            rng = np.random.default_rng(np.random.SeedSequence([rs, 0x5CE]))
            scene: Scene
            if kind == "materials":
                speed = round(_log_uniform(rng, 10.0, 40.0), 3)
                normal = round(_log_uniform(rng, 0.5, 2.0), 3)
                dur = seconds if seconds is not None else round(16.0 / speed, 4)
                scene = Slide(cls, speed_mm_s=speed, normal_n=normal, duration=dur, seed=rs)
            elif kind == "shake":
                grip = round(float(rng.uniform(1.0, 2.0)), 3)
                items, amp = None, BoxShake.amplitude_m
                if task_variation:
                    lo, hi = TASK_BOX_ITEMS[cls]
                    items = int(rng.integers(lo, hi + 1))
                    amp = round(amp * float(rng.uniform(*TASK_AMPLITUDE_GAIN)), 5)
                scene = BoxShake(cls, grip_n=grip, duration=5.6 if seconds is None
                                 else seconds, items=items, amplitude_m=amp, seed=rs)
            else:
                scene = CupStackSlide(speed_mm_s=round(float(rng.uniform(5.0, 20.0)), 3),
                                      normal_n=round(float(rng.uniform(0.3, 0.6)), 3),
                                      z_start_mm=round(float(rng.uniform(100.0, 140.0)), 2),
                                      seed=rs)
            plans.append(_Plan(cls, k, rs, scene))
    return plans


def _scene_params(scene: Scene) -> dict[str, Any]:
    d = dataclasses.asdict(scene)
    d.pop("signals", None)
    d["scene"] = scene.name
    return d


def write_vibration(out: str | os.PathLike, *, kind: str = "materials",
                    recordings_per_class: int | None = None, seconds: float | None = None,
                    seed: int = 0, rate: int = 44100, fmt: str = "wav",
                    params_file: str | os.PathLike | None = None, force: bool = False,
                    progress: bool = False,
                    on_recording: Callable[[str], None] | None = None,
                    task_variation: bool = False) -> DatasetResult:
    """Labelled recordings: ``OUT/<class>/<class>_NNNN.wav`` (16-bit PCM), ``manifest.csv``,
    ``dataset.json``; for cups also ``<class>_NNNN_rims.csv`` (rim, offset_mm, z_mm,
    passed, time_s, sample) and ``<class>_NNNN_z.csv`` (the robot's Z at 100 Hz).

    The audio is simulated at the sound card's rate (44.1 kHz) and resampled to ``rate``
    when that differs (:func:`resample`), then quantised to 16 bits.
    """
    n_rec = DEFAULT_RECORDINGS.get(kind, 1) if recordings_per_class is None \
        else check_int("recordings per class", recordings_per_class, 1, 100_000)
    seed = check_int("seed", seed, 0, 2 ** 31 - 1)
    rate = check_int("rate", rate, MIN_RATE_HZ, MAX_RATE_HZ)
    if fmt not in FORMATS:
        raise DatasetError(f"format must be one of {', '.join(FORMATS)}, not {fmt!r}")
    if seconds is not None:
        if kind == "cups":
            raise DatasetError("--seconds does not apply to cups: a cup recording lasts as "
                               "long as its 21 mm slide (0.3 s before and after)")
        if not (isinstance(seconds, (int, float)) and 0.05 <= seconds <= 600):
            raise DatasetError(f"seconds must be between 0.05 and 600, not {seconds!r}")
        seconds = float(seconds)
    if task_variation and kind != "shake":
        raise DatasetError(f"task variation applies to shake recordings only, not {kind!r}")
    plans = plan_vibration(kind, n_rec, seconds, seed, task_variation=task_variation)
    params, pfile = load_params_file(params_file)
    out = Path(out)
    w0 = time.monotonic()
    warnings = prepare_output(out, force)
    ext = "." + fmt
    files = []
    for pl in plans:
        files.append(pl.stem + ext)
        if kind == "cups":
            files += [pl.stem + "_rims.csv", pl.stem + "_z.csv"]
    files.append(MANIFEST_FILE)
    classes = list(dict.fromkeys(pl.cls for pl in plans))
    chain = AudioChain(params)
    meta: dict[str, Any] = {
        "generator": GENERATOR, "kind": "vibration", "vibration_kind": kind,
        "fingertip_version": __version__, "complete": False, "seed": seed,
        "classes": classes, "recordings_per_class": n_rec, "seconds": seconds,
        "task_variation": task_variation,
        "rate_hz": rate, "simulated_rate_hz": chain.fs,
        "resampled": rate != chain.fs, "format": fmt, "subtype": "PCM_16",
        "units": "1.0 = the sound card's full scale (1 V at its input)",
        "preamp_gain": chain.gain, "mains_hz": chain.mains_hz,
        "params_file": pfile or "fingertip/hardware/fingertip.toml (shipped)",
        "params_sha256": params_sha256(params_file),
        "manifest_columns": list(MANIFEST_COLUMNS), "files": files,
    }
    import soundfile as sf

    try:
        write_meta(out, meta)
        for c in classes:
            (out / c).mkdir(exist_ok=True)
        bar = Progress(len(plans), f"{kind} {out}", enabled=progress)
        with open(out / MANIFEST_FILE, "w", newline="", encoding="utf-8") as mf:
            mw = csv.writer(mf, lineterminator="\n")
            mw.writerow(MANIFEST_COLUMNS)
            for pl in plans:
                res = simulate(pl.scene, seed=pl.seed, chain=chain)
                assert res.audio is not None
                x = res.audio.samples
                if rate != chain.fs:
                    x = resample(x, chain.fs, rate)
                pcm = to_pcm(x, "int16")
                rel = pl.stem + ext
                sf.write(str(out / rel), pcm, rate, subtype="PCM_16", format=fmt.upper())
                if kind == "cups":
                    _write_cup_truth(out, pl, res.events, rate)
                xf = to_float(pcm)
                rms = float(np.sqrt(np.mean(xf ** 2))) if len(xf) else 0.0
                sp = _scene_params(pl.scene)
                speed = sp.get("speed_mm_s", "")
                normal = sp.get("normal_n", sp.get("grip_n", ""))
                mw.writerow([rel, pl.cls, pl.seed, f"{len(pcm) / rate:.6f}", rate, len(pcm),
                             speed, normal, f"{res.audio.clipped_fraction:.6g}",
                             f"{20 * math.log10(max(rms, 1e-12)):.2f}",
                             json.dumps(sp, sort_keys=True)])
                bar.step(rel)
                if on_recording is not None:
                    on_recording(rel)
        meta["complete"] = True
        meta["recordings"] = len(plans)
        write_meta(out, meta)
    except OSError as e:
        raise DatasetError(f"writing into {out} failed: {e.strerror or e}", 1) from e
    except sf.SoundFileError as e:
        raise DatasetError(f"writing audio into {out} failed: {e}", 1) from e
    return DatasetResult(out, [Path(f) for f in files], meta, warnings, time.monotonic() - w0)


def _write_cup_truth(out: Path, pl: _Plan, events: dict[str, Any], rate: int) -> None:
    scene = pl.scene
    assert isinstance(scene, CupStackSlide)
    offsets = events["rim_offsets_mm"]
    zs = events["rim_z_mm"]
    times = iter(events["rim_times_s"])
    with open(out / (pl.stem + "_rims.csv"), "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["rim", "offset_mm", "z_mm", "passed", "time_s", "sample"])
        for i, (off, z) in enumerate(zip(offsets, zs, strict=True)):
            passed = off < scene.slide_mm
            t = next(times) if passed else None
            w.writerow([i, f"{off:.4f}", f"{z:.4f}", int(passed),
                        "" if t is None else f"{t:.6f}",
                        "" if t is None else int(round(t * rate))])
    t = np.arange(0.0, scene.duration_s, 0.01)
    z = scene.z_mm(t)
    with open(out / (pl.stem + "_z.csv"), "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["time_s", "z_mm"])
        for ti, zi in zip(t, z, strict=True):
            w.writerow([f"{ti:.2f}", f"{zi:.4f}"])
