"""Vibration features for any sensor at any sample rate: log band spectrograms, gain-free.

The classifiers (:mod:`.material`, :mod:`.shake`) see a recording only through this module,
so that a model trained on one sensor can be trained (or judged) on recordings of another:

1. **Samples**: WAV / FLAC through soundfile, or CSV (:func:`read_recording`). NaN or
   infinite samples are a clear error (:class:`FeatureError`), never a silent NaN feature;
   the fraction of clipped samples is measured (:func:`clipped_fraction`) and flagged.
2. **Rate**: recordings above the canonical rate (16 kHz, :data:`CANONICAL_RATE`) are
   resampled down to it with ``scipy.signal.resample_poly`` (an anti-aliasing polyphase
   filter); recordings below it (down to 1 kHz) are used as they are. Frames are defined in
   seconds (32 ms Hann windows every 11.625 ms: 86 frames = 1.0 s, the paper's shake
   window), so the frame rate and the frequency resolution (about 31 Hz) are the same at
   every rate.
3. **Bands**: :data:`N_BANDS` triangular bands with log-spaced centres from 100 Hz (above
   mains hum and its first harmonic) to ``f_hi``, by default 0.9 x the Nyquist frequency of
   the lowest rate of the data (at most 7.2 kHz), so every rate gives the same feature shape,
   and a model knows the band edges it was trained with (:class:`FeatureConfig`, stored in
   the model). Band values are power spectral densities (input units^2 / Hz).
4. **Gain**: each classifier window is divided by its own mean band power before the log
   (:func:`~.window_features.log_window`), so the absolute gain of a sensor, preamp or
   sound card does not matter. A floor (``floor_db``, -80 dB below the window's mean)
   keeps silence and extreme values finite: an all-zero window gives ``floor_db``
   everywhere, and features are bounded by ``floor_db`` and ``10 log10(frames x bands)``.

Why 16 kHz: a model is only as portable as its bands. Resampled to 16 kHz, every recording
at 16 kHz or more (most sound cards, contact microphones and public vibration sets) feeds
the same 100 Hz-7.2 kHz bands, so a model trained on one sensor at 44.1 kHz runs on another
at 16, 22.05 or 48 kHz without retraining; 32 bands over those 6 octaves keep about 5 per
octave where the fingertip's cap modes, textures and impacts lie. Below 16 kHz the bands
shrink to the recording's own Nyquist (retrain, or cap a model with ``max_hz``). Measured
(docs/classifiers.md): the whole path costs about 1.6 ms per second of 44.1 kHz audio,
resampling included; on the simulator, bands up to 14.4 kHz (32 kHz) add about one point of
material accuracy, because the simulated wax paper and copper tape differ above 8 kHz.

This module holds the configuration, the recordings (reading, checks, clipping), the rate
and the bands; :mod:`.spectrogram` computes the band power (the STFT) and
:mod:`.window_features` the classifier windows' features from it. Imports numpy and scipy
only.
"""
from __future__ import annotations

import csv
import io
import logging
import math
import re
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace
from fractions import Fraction
from pathlib import Path

import numpy as np
from scipy.signal import resample_poly

from ...audio.sanity import clipped_fraction, clipped_mask  # noqa: F401  (public names here)
from ...errors import BadFileError

log = logging.getLogger(__name__)

CANONICAL_RATE = 16_000
"""Hz. Recordings above it are resampled down to it; below it they are used as they are."""
MIN_RATE = 1_000.0
MAX_RATE = 384_000.0
HOP_S = 186 / 16_000
"""Frame hop, 11.625 ms: 86 frames span 1.0 s (the paper's 86-frame shake window)."""
WIN_S = 0.032
"""Frame length (Hann), 32 ms: about 31 Hz resolution at every rate."""
F_LO_HZ = 100.0
N_BANDS = 32
TOP_FRACTION = 0.9
"""Bands end at this fraction of the Nyquist frequency (above: anti-alias roll-off)."""
FLOOR_DB = -80.0
SCALES = ("log", "linear")
CLIP_FLAG = 1e-3
"""A recording with more than this fraction of clipped samples is flagged."""
AUDIO_EXTENSIONS = (".wav", ".flac")
CSV_EXTENSIONS = (".csv", ".txt")


class FeatureError(BadFileError):
    """A recording that cannot give features: unreadable, NaN/Inf, bad rate, too short (a
    :class:`~fingertip.errors.BadFileError`, so a ValueError)."""


class NonFiniteSamples(FeatureError):
    """A recording holding NaN or infinite samples."""


# --- configuration ------------------------------------------------------------------------

@dataclass(frozen=True)
class FeatureConfig:
    """Everything that defines the features; stored in every model's metadata."""

    canonical_rate: int = CANONICAL_RATE
    n_bands: int = N_BANDS
    f_lo: float = F_LO_HZ
    f_hi: float | None = None
    """Top of the last band, Hz. None: decided from the data (:meth:`for_rates`)."""
    win_s: float = WIN_S
    hop_s: float = HOP_S
    floor_db: float = FLOOR_DB
    scale: str = "log"
    """Band spacing: ``log`` (geometric centres) or ``linear`` (equal widths: with about one
    band per FFT bin, the plain log spectrum of the baseline classifier)."""
    mains_notch: bool = False
    """Notch out stationary 50/60 Hz lines found in each recording's own spectrum before
    the spectrogram (:mod:`fingertip.models.vibration.mains`). Models saved before this option
    existed load with it off (:meth:`from_dict`)."""
    linear_bins: int = 0
    """Also this many equal-width bands over the same range, after the ``n_bands`` bands
    (one spectrogram with both views: the ensemble candidate's baseline member reads the
    plain log spectrum, its other members the log bands). Older models load with none."""

    def __post_init__(self) -> None:
        if self.scale not in SCALES:
            raise FeatureError(f"scale must be one of {SCALES}, not {self.scale!r}")
        if not 1_000 <= self.canonical_rate <= 192_000:
            raise FeatureError(f"canonical rate {self.canonical_rate} Hz is out of range")
        if not 4 <= self.n_bands <= 256:
            raise FeatureError(f"n_bands must be 4..256, not {self.n_bands}")
        if not (self.linear_bins == 0 or 4 <= self.linear_bins <= 256):
            raise FeatureError(f"linear_bins must be 0 or 4..256, not {self.linear_bins}")
        if not 0 < self.f_lo < (self.f_hi or math.inf):
            raise FeatureError(f"need 0 < f_lo < f_hi, got {self.f_lo} and {self.f_hi}")
        if not (0 < self.hop_s <= self.win_s <= 1.0):
            raise FeatureError("need 0 < hop_s <= win_s <= 1 s")
        if not -200 <= self.floor_db < 0:
            raise FeatureError("floor_db must be negative (-200..0 dB)")

    def top_for_rate(self, rate: float) -> float:
        """The highest band edge a recording at ``rate`` supports."""
        return TOP_FRACTION * min(float(rate), float(self.canonical_rate)) / 2

    def for_rates(self, rates: Sequence[float], max_hz: float | None = None
                  ) -> FeatureConfig:
        """This configuration with ``f_hi`` fixed for recordings at ``rates`` (the lowest
        one decides), capped at ``max_hz``."""
        if not len(rates):
            raise FeatureError("no recordings to decide the band range from")
        for r in rates:
            check_rate(r)
        top = min(self.top_for_rate(r) for r in rates)
        if max_hz is not None:
            if not max_hz > self.f_lo * 2:
                raise FeatureError(f"max_hz must be above {2 * self.f_lo:g} Hz, not {max_hz}")
            top = min(top, float(max_hz))
        return replace(self, f_hi=round(top, 3))

    def resolved(self, rate: float) -> FeatureConfig:
        return self if self.f_hi is not None else self.for_rates([rate])

    def check_supports(self, rate: float, what: str = "the recording") -> None:
        """Raise when a recording at ``rate`` cannot fill the bands up to ``f_hi``."""
        check_rate(rate, what)
        if self.f_hi is not None and self.top_for_rate(rate) < self.f_hi * (1 - 1e-6):
            need = math.ceil(self.f_hi / TOP_FRACTION * 2)
            raise FeatureError(
                f"{what} is sampled at {rate:g} Hz: its spectrum stops at {rate / 2:g} Hz, "
                f"but the model's bands reach {self.f_hi:g} Hz. Use recordings at {need} Hz "
                f"or more, or retrain with --max-hz {self.top_for_rate(rate):g} (or with "
                f"recordings at this rate)")

    def band_edges(self) -> np.ndarray:
        """n_bands + 2 log-spaced frequencies: band k rises from edge k, peaks at edge
        k + 1 (its centre) and falls to edge k + 2."""
        if self.f_hi is None:
            raise FeatureError("f_hi is not decided yet (FeatureConfig.for_rates)")
        if self.scale == "linear":
            return np.linspace(self.f_lo, self.f_hi, self.n_bands + 2)
        return np.geomspace(self.f_lo, self.f_hi, self.n_bands + 2)

    def band_centres(self) -> np.ndarray:
        return self.band_edges()[1:-1]

    @property
    def split(self) -> int:
        """Where the linear bins start (0: none), for :func:`log_window`."""
        return self.n_bands if self.linear_bins else 0

    @property
    def total_bands(self) -> int:
        """Columns of the spectrogram: the bands, then the extra linear bins."""
        return self.n_bands + self.linear_bins

    def band_weights(self, freqs: np.ndarray) -> np.ndarray:
        """(bins, :attr:`total_bands`) weights of FFT bins ``freqs``: the bands of
        :meth:`band_edges`, then ``linear_bins`` equal-width bands over the same range."""
        w = band_matrix(freqs, self.band_edges())
        if not self.linear_bins:
            return w
        lin = replace(self, scale="linear", n_bands=self.linear_bins, linear_bins=0)
        return np.hstack([w, band_matrix(freqs, lin.band_edges())])

    def frames_for(self, seconds: float) -> int:
        """Frames whose hop spans ``seconds`` (at least 1)."""
        return max(1, int(round(seconds / self.hop_s)))

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> FeatureConfig:
        known = {f for f in cls.__dataclass_fields__}
        kw = {k: v for k, v in d.items() if k in known}
        kw.setdefault("mains_notch", False)  # older models were trained without the notch
        return cls(**kw)


def check_rate(rate: float, what: str = "the recording") -> float:
    try:
        r = float(rate)
    except (TypeError, ValueError):
        raise FeatureError(f"{what}: sample rate {rate!r} is not a number") from None
    if not (MIN_RATE <= r <= MAX_RATE):  # also refuses NaN
        raise FeatureError(f"{what}: sample rate {rate!r} Hz is outside "
                           f"{MIN_RATE:g}..{MAX_RATE:g} Hz")
    return r


# --- recordings ---------------------------------------------------------------------------

@dataclass
class Recording:
    """One mono recording as float samples (the file's units; WAV/FLAC: 1.0 = full scale)."""

    samples: np.ndarray
    rate: float
    source: str = ""
    full_scale: float | None = None
    """Known full scale (WAV/FLAC: 1.0); None for CSV and arrays."""
    clipped_fraction: float = 0.0
    meta: dict = field(default_factory=dict)

    @property
    def duration(self) -> float:
        return len(self.samples) / self.rate

    @property
    def clipped(self) -> bool:
        return self.clipped_fraction > CLIP_FLAG


def check_finite(x: np.ndarray, what: str = "the recording", rate: float | None = None
                 ) -> None:
    """Raise :class:`FeatureError` naming how many samples are NaN/infinite and where."""
    bad = ~np.isfinite(x)
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        n_nan = int(np.count_nonzero(np.isnan(x)))
        at = f" ({first / rate:.4f} s)" if rate else ""
        raise NonFiniteSamples(f"{what} holds {n_nan} NaN and {int(bad.sum()) - n_nan} infinite "
                           f"sample(s), the first at sample {first}{at}: repair or cut it "
                           "(features of non-finite samples would be meaningless)")


def as_recording(x: np.ndarray, rate: float, source: str = "array",
                 full_scale: float | None = None) -> Recording:
    """Validate an array of samples ((n,) or (n, channels): channel 0 is used)."""
    rate = check_rate(rate, source)
    a = np.asarray(x)
    if a.ndim == 2:
        a = a[:, 0]
    if a.ndim != 1:
        raise FeatureError(f"{source}: samples must be (n,) or (n, channels), not {a.shape}")
    if a.dtype.kind in "iu":
        info = np.iinfo(a.dtype)
        fs = float(-int(info.min)) if info.min < 0 else float(info.max + 1) / 2
        a = (a.astype(np.float64) - (0 if info.min < 0 else fs)) / fs
        full_scale = 1.0
    elif a.dtype.kind != "f":
        raise FeatureError(f"{source}: samples must be numbers, not {a.dtype}")
    check_finite(a, source, rate)
    return Recording(a, rate, source, full_scale, clipped_fraction(a, full_scale))


_RATE_RE = re.compile(r"(?:sample[_ ]?rate(?:_hz)?|rate(?:_hz)?|fs|samplerate)\s*[=:]\s*"
                      r"([0-9.eE+]+)", re.IGNORECASE)
_TIME_NAMES = {"t", "time", "time_s", "t_s", "seconds", "timestamp"}


def _read_csv(path: Path, rate: float | None) -> Recording:
    """CSV: one column of samples (numbers; '#' lines are comments). The rate comes from a
    header line such as ``# rate=8000`` (also ``sample_rate``, ``fs``, ``rate_hz``, with ``=``
    or ``:``), or from ``rate``. A first row of column names is skipped; with two columns
    and a time column (``time``, ``t``, ``time_s``...), the other one is the signal (and the
    rate, if stated nowhere, comes from the time steps)."""
    try:
        text = path.read_text(encoding="utf-8-sig", errors="replace")
    except OSError as e:
        raise FeatureError(f"{path}: cannot read ({e.strerror or e})") from e
    stated = None
    body = []
    for line in text.splitlines():
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            m = _RATE_RE.search(s)
            if m and stated is None:
                stated = float(m.group(1))
            continue
        body.append(s)
    if not body:
        raise FeatureError(f"{path}: no samples")
    delim = next((d for d in (",", ";", "\t") if d in body[0]), None)
    rows = csv.reader(io.StringIO("\n".join(body)), delimiter=delim or " ",
                      skipinitialspace=True)
    first = next(rows)
    header = None
    try:
        [float(v) for v in first if v != ""]
    except ValueError:
        header = [v.strip().lower() for v in first]
        m = _RATE_RE.search(",".join(first))
        if m and stated is None:
            stated = float(m.group(1))
    if header is not None and len(body) == 1:
        raise FeatureError(f"{path}: no samples (only a line of text: "
                           f"{', '.join(first)[:60]!r})")
    col, tcol = 0, None
    if header is not None and len(header) >= 2:
        tcols = [i for i, h in enumerate(header) if h in _TIME_NAMES]
        if tcols:
            tcol = tcols[0]
            col = next(i for i in range(len(header)) if i != tcol)
    cols = [c for c in (col, tcol) if c is not None]
    try:
        data = np.loadtxt(io.StringIO("\n".join(body[1 if header else 0:])), delimiter=delim,
                          usecols=cols, ndmin=2, dtype=np.float64)
    except ValueError as e:
        raise FeatureError(f"{path}: not a CSV of numbers ({e})") from e
    x = data[:, 0]
    if stated is None and tcol is not None and len(data) > 2:
        dt = np.median(np.diff(data[:, 1]))
        if dt > 0:
            stated = 1.0 / dt
    if stated is not None and rate is not None and abs(stated - rate) > 1e-6 * rate:
        log.warning("%s states %g Hz; using it, not the %g Hz given", path, stated, rate)
    r = stated if stated is not None else rate
    if r is None:
        raise FeatureError(f"{path}: no sample rate: add a header line '# rate=8000' to the "
                           "file, or give the rate (--rate / --rate-hint)")
    rec = as_recording(x, r, str(path))
    rec.meta["format"] = "csv"
    return rec


def read_recording(path: str | Path, rate: float | None = None, channel: int = 0
                   ) -> Recording:
    """A WAV/FLAC (soundfile; ``channel`` of several) or CSV recording (``rate``: the rate of
    a CSV that does not state its own)."""
    path = Path(path)
    if not path.is_file():
        raise FeatureError(f"{path}: no such file")
    if path.suffix.lower() in CSV_EXTENSIONS:
        return _read_csv(path, rate)
    from ...audio.file import read_audio_file
    from ...audio.source import AudioFileError

    try:
        audio = read_audio_file(path)
    except AudioFileError as e:
        raise FeatureError(str(e)) from e
    data = audio.samples
    if not 0 <= channel < data.shape[1]:
        raise FeatureError(f"{path}: has {data.shape[1]} channel(s), no channel {channel}")
    rec = as_recording(data[:, channel], audio.rate, str(path), full_scale=1.0)
    rec.meta["format"] = path.suffix.lower().lstrip(".")
    if audio.missing_frames:
        rec.meta["truncated_frames"] = audio.missing_frames
    return rec


# --- rate ---------------------------------------------------------------------------------

def resample_ratio(rate: float, canonical: int = CANONICAL_RATE) -> tuple[int, int]:
    """(up, down) taking ``rate`` to about ``canonical``; (1, 1) at or below it."""
    if rate <= canonical:
        return 1, 1
    fr = Fraction(canonical / rate).limit_denominator(1000)
    return fr.numerator, fr.denominator


def to_working_rate(x: np.ndarray, rate: float, canonical: int = CANONICAL_RATE
                    ) -> tuple[np.ndarray, float]:
    """Samples at the working rate: resampled down to ``canonical`` (polyphase filter with
    a Kaiser window) when above it, unchanged otherwise. Returns (samples, rate)."""
    up, down = resample_ratio(rate, canonical)
    if up == down:
        return x, float(rate)
    y = resample_poly(x, up, down)
    return y, rate * up / down


# --- bands ------------------------------------------------------------------------------

def band_matrix(freqs: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """(bins, bands) triangular weights, each band at least one bin wide on each side of
    its centre, each column summing to 1 (a band is a weighted mean of bin powers)."""
    df = float(freqs[1] - freqs[0])
    nb = len(edges) - 2
    w = np.zeros((len(freqs), nb))
    for k in range(nb):  # once per band at construction, not per frame
        lo, c, hi = edges[k], edges[k + 1], edges[k + 2]
        lo, hi = min(lo, c - df), max(hi, c + df)
        up = (freqs - lo) / (c - lo)
        down = (hi - freqs) / (hi - c)
        w[:, k] = np.clip(np.minimum(up, down), 0, None)
    s = w.sum(axis=0)
    if np.any(s <= 0):  # cannot happen with the one-bin minimum; guard anyway
        raise FeatureError("a band has no frequency bin")
    return w / s


STATS = ("mean", "std", "flux")
"""The default summary of a window (what models without a ``stats`` entry were made with)."""
KNOWN_STATS = (*STATS, "p90")
