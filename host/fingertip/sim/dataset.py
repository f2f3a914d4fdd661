"""Datasets from the virtual fingertip: calibration sweeps and labelled vibration recordings.

``fingertip sim dataset calibration OUT`` and ``fingertip sim dataset vibration OUT`` (see
:mod:`fingertip.cli.sim`) call :func:`write_calibration` and :func:`write_vibration`.

- Calibration: the paper's sweep (:func:`~fingertip.sim.physics.calibration_sweep`) on one
  or more virtual units, one CSV per unit, in the layout of ``fingertip export``'s
  ``<name>.csv`` (``device_time_us``, ``ch0..ch3``, masks, ``fx fy fz``) plus the sweep's
  ground truth (angle, contact height, displacement, loading/unloading, trial, step, unit).
- Vibration: one sub-folder per class of WAV (or FLAC) files, the layout that
  ``fingertip train material|shake FOLDER`` reads, a ``manifest.csv`` (file, class, seed,
  the scene's parameters) and, for cup slides, sidecar CSVs of rim times and robot Z.

Every folder gets a ``dataset.json`` (what was written, with which parameters and the
SHA-256 of the parameter file). It is written first with ``"complete": false`` and
rewritten at the end, so an interrupted run is recognisable. Files hold no wall-clock time:
the same arguments and seed give byte-identical files. See docs/simulation.md.
"""
from __future__ import annotations

import csv
import dataclasses
import hashlib
import json
import math
import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from .. import __version__
from ..audio.pcm import to_float, to_pcm
from ..protocol.messages import INT24_MAX, INT24_MIN
from .physics import (
    BOX_CONTENTS,
    PAPER_SEVEN,
    AudioChain,
    BoxShake,
    CupStackSlide,
    Scene,
    Slide,
    VirtualStrainSensor,
    calibration_sweep,
    load,
    params_path,
    simulate,
)
from .physics.vibration import good_fft_size

GENERATOR = "fingertip sim dataset"
META_FILE = "dataset.json"
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

CALIBRATION_COLUMNS: dict[str, str] = {
    "unix_time": "seconds; simulated: device time since the session start (no wall clock, "
                 "so that files are reproducible)",
    "host_time": "seconds; simulated: equal to unix_time (a host clock locked to the device)",
    "device_time_us": "the conversion's device timestamp, microseconds (int)",
    "seq": "the conversion's number since boot (device time / period), modulo 2^16; only "
           "the readings at the end of each pause are written, so it jumps between rows",
    "arrival_time": "seconds; simulated: equal to host_time",
    "ch0": "HX711 counts of the +x gauge at gain 128, as streamed (after the tare)",
    "ch1": "same, +y gauge",
    "ch2": "same, -x gauge",
    "ch3": "same, -y gauge",
    "timeout_mask": "bit i set: chip i did not answer (always 0 here)",
    "saturation_mask": "bit i set: channel i at the ADC's limit (-2^23 or 2^23-1)",
    "fx": "true force on the fingertip along x, N (in a real session: the F/T sensor)",
    "fy": "true force along y, N",
    "fz": "true axial force, N (0 in this sweep)",
    "angle_deg": "indentation direction in the XY plane, degrees (-50..50)",
    "height_mm": "contact height below the nail tip, mm (0..5)",
    "displacement_mm": "indenter travel from its start position, mm (steps of 1.5 mm)",
    "phase": "loading (travel increasing) or unloading (retracting)",
    "trial": "trial number within the sweep (angles and heights in random order)",
    "step": "step number within the trial",
    "sweep": "sweep number for this unit (0..sweeps-1)",
    "unit_seed": "which virtual fingertip (its per-unit variation)",
}

MANIFEST_COLUMNS = ("file", "class", "seed", "duration_s", "rate_hz", "frames", "speed_mm_s",
                    "normal_n", "clipped_fraction", "rms_dbfs", "params")


class DatasetError(RuntimeError):
    """The dataset cannot be written. ``code``: 2 for a user error (bad argument, output
    folder not empty or not writable), 1 when writing failed part-way (disk full...)."""

    def __init__(self, message: str, code: int = 2) -> None:
        super().__init__(message)
        self.code = code


# --- progress -----------------------------------------------------------------------------

class Progress:
    """A one-line progress report on stderr: rewritten in place on a terminal; otherwise a
    line at about every tenth of the work once it has run 2 s, and one at the end.
    ``enabled=False``: silent."""

    def __init__(self, total: int, label: str, stream: TextIO | None = None,
                 enabled: bool = True) -> None:
        self.total = max(1, total)
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.enabled = enabled
        self.done = 0
        self.t0 = time.monotonic()
        self._tty = enabled and bool(getattr(self.stream, "isatty", lambda: False)())
        self._last_decile = -1
        self._last_draw = 0.0

    def step(self, what: str = "") -> None:
        self.done += 1
        if not self.enabled:
            return
        now = time.monotonic()
        end = self.done >= self.total
        pct = 100 * self.done // self.total
        if self._tty:
            if end or now - self._last_draw >= 0.1:
                self._last_draw = now
                self.stream.write(f"\r{self.label}: {self.done}/{self.total} ({pct:3d} %) "
                                  f"{now - self.t0:5.1f} s  {what[-40:]:<40}")
                if end:
                    self.stream.write("\n")
                self.stream.flush()
        elif end or (pct // 10 > self._last_decile and now - self.t0 >= 2.0):
            self._last_decile = pct // 10
            self.stream.write(f"{self.label}: {self.done}/{self.total} ({pct} %) "
                              f"{now - self.t0:.1f} s\n")
            self.stream.flush()


# --- output folder ------------------------------------------------------------------------

def params_sha256(path: str | os.PathLike | None) -> str:
    data = (Path(path) if path is not None else params_path()).read_bytes()
    return hashlib.sha256(data).hexdigest()


def _ours(out: Path) -> dict[str, Any] | None:
    try:
        meta = json.loads((out / META_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return meta if isinstance(meta, dict) and meta.get("generator") == GENERATOR else None


def prepare_output(out: str | os.PathLike, force: bool = False) -> list[str]:
    """Make ``out`` ready for a new dataset; returns warnings.

    An existing non-empty folder is refused unless ``force``. With ``force``, the files of
    a dataset this command wrote there before (listed in its dataset.json) are removed
    first, so no stale class folder survives; anything else is left alone (and reported),
    never deleted.
    """
    out = Path(out)
    warnings: list[str] = []
    if out.exists() and not out.is_dir():
        raise DatasetError(f"{out} exists and is not a folder")
    if out.is_dir():
        try:
            entries = sorted(p.name for p in out.iterdir())
        except OSError as e:
            raise DatasetError(f"cannot read {out}: {e.strerror or e}") from e
        if entries and not force:
            raise DatasetError(
                f"{out} is not empty ({len(entries)} entries, e.g. {entries[0]!r}): choose a "
                f"new folder, or add --force to replace a dataset written there")
        if entries:
            meta = _ours(out)
            if meta is not None:
                _remove_dataset(out, meta)
            left = sorted(p.name for p in out.iterdir())
            if left:
                warnings.append(f"{out} holds {len(left)} entries this command did not write "
                                f"(left in place): {', '.join(left[:5])}"
                                + (" ..." if len(left) > 5 else ""))
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / ".fingertip-dataset-probe"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as e:
        raise DatasetError(f"cannot write into {out}: {e.strerror or e}") from e
    return warnings


def _remove_dataset(out: Path, meta: dict[str, Any]) -> None:
    root = out.resolve()
    dirs = set()
    for rel in [*meta.get("files", []), META_FILE]:
        p = (out / rel).resolve()
        if root not in p.parents:  # never outside the folder, whatever the file says
            continue
        try:
            p.unlink()
        except FileNotFoundError:
            pass
        except OSError as e:
            raise DatasetError(f"cannot remove {p} of the old dataset: {e.strerror or e}") \
                from e
        dirs.update(d for d in p.parents if root in d.parents)
    for d in sorted(dirs, key=lambda d: len(d.parts), reverse=True):
        try:
            d.rmdir()  # only if empty
        except OSError:
            pass


def _write_meta(out: Path, meta: dict[str, Any]) -> None:
    tmp = out / (META_FILE + ".tmp")
    tmp.write_text(json.dumps(meta, indent=1) + "\n", encoding="utf-8")
    os.replace(tmp, out / META_FILE)


@dataclass
class DatasetResult:
    out: Path
    files: list[Path] = field(default_factory=list)
    """Every file written (relative to ``out``), dataset.json excluded."""
    meta: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    wall_s: float = 0.0


def _check_int(name: str, value: int, lo: int, hi: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise DatasetError(f"{name} must be an integer, not {value!r}")
    if value < lo or (hi is not None and value > hi):
        raise DatasetError(f"{name} must be " + (f"between {lo} and {hi}" if hi is not None
                                                 else f"at least {lo}") + f", not {value}")
    return int(value)


def _load_params(params_file: str | os.PathLike | None):
    if params_file is None:
        return load(), None
    try:
        return load(params_file), str(params_file)
    except OSError as e:
        raise DatasetError(f"cannot read {params_file}: {e.strerror or e}") from e
    except ValueError as e:
        raise DatasetError(f"bad parameter file {params_file}: {e}") from e


def _derived_seed(*parts: int) -> int:
    return int(np.random.SeedSequence(list(parts)).generate_state(1)[0] & 0x7FFFFFFF)


# --- calibration --------------------------------------------------------------------------

def write_calibration(out: str | os.PathLike, *, units: int = 1, seed: int = 0,
                      sweeps: int = 1, rate_sps: int = 80, samples_per_step: int = 1,
                      tare_samples: int = 16, max_force_n: float = 5.0,
                      params_file: str | os.PathLike | None = None, force: bool = False,
                      progress: bool = False) -> DatasetResult:
    """The paper's calibration sweep on units ``seed .. seed + units - 1``: one CSV per unit
    (``unit_<seed>.csv``, columns :data:`CALIBRATION_COLUMNS`) and ``dataset.json``.

    Each unit is tared first with ``tare_samples`` readings at zero load (as ``fingertip
    tare`` does on the device; 0: raw counts with their offsets of a few 1e5), then swept
    ``sweeps`` times in a row (one continuous history: hysteresis and creep carry over;
    each sweep draws its own trial order and contact points).
    """
    units = _check_int("units", units, 1, 10_000)
    seed = _check_int("seed", seed, 0, 2 ** 31 - 1 - units)
    sweeps = _check_int("sweeps", sweeps, 1, 100)
    samples_per_step = _check_int("samples per step", samples_per_step, 1, 64)
    tare_samples = _check_int("tare samples", tare_samples, 0, 256)
    if rate_sps not in (10, 80):
        raise DatasetError(f"rate must be 10 or 80 SPS (the HX711's RATE pin), not {rate_sps}")
    if not (isinstance(max_force_n, (int, float)) and 0 < max_force_n <= 50):
        raise DatasetError(f"max force must be in (0, 50] N, not {max_force_n!r}")
    params, pfile = _load_params(params_file)
    out = Path(out)
    w0 = time.monotonic()
    warnings = prepare_output(out, force)
    unit_seeds = [seed + i for i in range(units)]
    files = [f"unit_{s}.csv" for s in unit_seeds]
    period_us = 1_000_000 // rate_sps
    meta: dict[str, Any] = {
        "generator": GENERATOR, "kind": "calibration", "fingertip_version": __version__,
        "complete": False, "seed": seed, "units": unit_seeds, "sweeps_per_unit": sweeps,
        "rate_sps": rate_sps, "gain": 128, "channels": 4, "format": "csv",
        "params_file": pfile or "fingertip/sim/physics/fingertip.toml (shipped)",
        "params_sha256": params_sha256(params_file),
        "protocol": {"angles_deg": list(range(-50, 51, 10)), "heights_mm": [0, 1, 2, 3, 4, 5],
                     "step_mm": 1.5, "travel_mm": 30.0, "pause_s": 8.0, "move_s": 0.5,
                     "rest_s": 5.0, "samples_per_step": samples_per_step,
                     "max_force_n": float(max_force_n), "randomized": True},
        "tare_samples": tare_samples, "tare_offsets": {}, "rows": {},
        "columns": CALIBRATION_COLUMNS, "files": files,
    }
    try:
        _write_meta(out, meta)
        bar = Progress(units * sweeps, f"calibration {out}", enabled=progress)
        for unit, name in zip(unit_seeds, files, strict=True):
            sensor = VirtualStrainSensor(unit, params=params, rate_sps=rate_sps)
            offsets = [0, 0, 0, 0]
            t_next_us = 0
            if tare_samples:
                t = period_us * (1 + np.arange(tare_samples, dtype=np.int64))
                raw = sensor.counts_batch(np.zeros((tare_samples, 2)), 0.0, t * 1e-6)
                s = raw.sum(axis=0)
                n = tare_samples
                offsets = [int((abs(int(v)) + n // 2) // n * (1 if v >= 0 else -1)) for v in s]
                t_next_us = int(t[-1])
            rows = 0
            with open(out / name, "w", newline="", encoding="utf-8") as f:
                w = csv.writer(f, lineterminator="\n")
                w.writerow(CALIBRATION_COLUMNS)
                for k in range(sweeps):
                    sw = calibration_sweep(
                        sensor, seed=_derived_seed(seed, unit, k, 0xCA1),
                        samples_per_step=samples_per_step, max_force_n=float(max_force_n),
                        t0_us=t_next_us + 1_000_000)
                    _write_sweep_rows(w, sw, offsets, period_us, k, unit)
                    rows += len(sw)
                    t_next_us = int(sw.t_us[-1])
                    bar.step(f"{name} sweep {k}")
            meta["tare_offsets"][name] = offsets
            meta["rows"][name] = rows
        meta["complete"] = True
        _write_meta(out, meta)
    except OSError as e:
        raise DatasetError(f"writing into {out} failed: {e.strerror or e}", 1) from e
    return DatasetResult(out, [Path(n) for n in files], meta, warnings, time.monotonic() - w0)


def _write_sweep_rows(w, sw, offsets: Sequence[int], period_us: int, sweep: int,
                      unit: int) -> None:
    counts = np.clip(sw.counts - np.asarray(offsets, dtype=np.int64), INT24_MIN, INT24_MAX)
    sat = (sw.counts <= INT24_MIN) | (sw.counts >= INT24_MAX) \
        | (sw.counts - np.asarray(offsets) < INT24_MIN) \
        | (sw.counts - np.asarray(offsets) > INT24_MAX)
    smask = (sat * (1 << np.arange(4))).sum(axis=1)
    for i in range(len(sw)):
        t_us = int(sw.t_us[i])
        t_s = f"{t_us / 1e6:.6f}"
        c = counts[i]
        w.writerow([t_s, t_s, t_us, (t_us // period_us) & 0xFFFF, t_s,
                    int(c[0]), int(c[1]), int(c[2]), int(c[3]), 0, int(smask[i]),
                    repr(float(sw.fx[i])), repr(float(sw.fy[i])), "0.0",
                    repr(float(sw.angle_deg[i])), repr(float(sw.height_mm[i])),
                    repr(float(sw.displacement_mm[i])),
                    "loading" if sw.loading[i] else "unloading",
                    int(sw.trial[i]), int(sw.step[i]), sweep, unit])


def read_calibration_csv(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """A calibration CSV as columns: numbers as int64/float64 arrays, ``phase`` as strings.
    Reads any CSV with a header (a real session's export with reference forces too)."""
    with open(path, newline="", encoding="utf-8") as f:
        r = csv.reader(f)
        try:
            head = next(r)
        except StopIteration:
            raise DatasetError(f"{path} is empty") from None
        cols: list[list[str]] = [[] for _ in head]
        for row in r:
            for c, v in zip(cols, row, strict=False):
                c.append(v)
    out: dict[str, np.ndarray] = {}
    for name, values in zip(head, cols, strict=True):
        out[name] = _column(values)
    return out


def _column(values: list[str]) -> np.ndarray:
    try:
        return np.array(values, dtype=np.int64)
    except ValueError:
        pass
    try:
        return np.array([float(v) if v != "" else math.nan for v in values])
    except ValueError:
        return np.array(values, dtype=str)


# --- vibration ----------------------------------------------------------------------------

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
            rs = _derived_seed(seed, kind_tag, ci, k)
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
        else _check_int("recordings per class", recordings_per_class, 1, 100_000)
    seed = _check_int("seed", seed, 0, 2 ** 31 - 1)
    rate = _check_int("rate", rate, MIN_RATE_HZ, MAX_RATE_HZ)
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
    params, pfile = _load_params(params_file)
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
        "params_file": pfile or "fingertip/sim/physics/fingertip.toml (shipped)",
        "params_sha256": params_sha256(params_file),
        "manifest_columns": list(MANIFEST_COLUMNS), "files": files,
    }
    import soundfile as sf

    try:
        _write_meta(out, meta)
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
        _write_meta(out, meta)
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

