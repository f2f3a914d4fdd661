"""Float samples (1.0 = full scale) to and from the integer formats a sound card delivers.

One rule for every writer of integer samples (the simulated card, the simulator's WAV files,
the playback into a sound server): scale by the format's full scale (32768 for int16),
round to the nearest integer and clip like a card's converter. Reading back divides by the
same full scale, so a 16-bit sample k is exactly k / 32768.
"""
from __future__ import annotations

import numpy as np

FULL_SCALE = {np.dtype(np.int16): 32768.0, np.dtype(np.int32): 2147483648.0}
"""Integer sample formats and the value that stands for 1.0."""
_LIMITS = {dt: (float(np.iinfo(dt).min), float(np.iinfo(dt).max)) for dt in FULL_SCALE}


def to_pcm(x: np.ndarray, dtype: str | np.dtype = "int16", *, out: np.ndarray | None = None,
           work: np.ndarray | None = None) -> np.ndarray:
    """``x`` (float, 1.0 = full scale) as ``dtype`` (int16 or int32): scaled, rounded and
    clipped to the format's range. ``out`` (that dtype) and ``work`` (float64, ``out``'s
    shape) are optional buffers for a caller that converts block after block; ``x`` must
    broadcast to ``out``'s shape."""
    dt = np.dtype(dtype)
    if dt not in FULL_SCALE:
        raise ValueError(f"integer samples are int16 or int32, not {dt}")
    lo, hi = _LIMITS[dt]
    f = np.multiply(x, FULL_SCALE[dt], out=work, dtype=np.float64)
    np.rint(f, out=f)
    np.minimum(f, hi, out=f)
    np.maximum(f, lo, out=f)
    if out is None:
        return f.astype(dt)
    np.copyto(out, f, casting="unsafe")
    return out


def to_float(x: np.ndarray) -> np.ndarray:
    """int16, int32 or float samples -> float64, 1.0 = full scale."""
    x = np.asarray(x)
    scale = FULL_SCALE.get(x.dtype)
    if scale is None:
        return x.astype(np.float64)
    return x.astype(np.float64) / scale
