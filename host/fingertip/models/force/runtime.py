"""Run a force calibration: HX711 counts -> (Fx, Fy) in newtons, with onnxruntime.

Needs only numpy and onnxruntime. The ONNX file comes from ``fingertip calibrate fit``
(:mod:`fingertip.models.force.calibrate`); its metadata tells the channel count, the units, the
gain the counts were recorded at, the held-out error and the range of counts seen in
calibration.

    >>> fm = ForceModel("calibration/force.onnx")          # doctest: +SKIP
    >>> fx, fy = fm.estimate([12000, -3000, -11000, 2500])  # one frame (tared counts)
    >>> forces = fm.estimate(counts_n_by_4)                # a batch: (N, 2)
    >>> est = fm.estimate_frame(frame)                     # a fingertip.Frame: masks honoured
    >>> est.ok, est.fx, est.fy, est.status

Invalid input never produces a number: a row with a NaN or infinite count, a count at the
24-bit limits (-2^23 or 2^23-1), or a channel flagged in the frame's ``saturation_mask`` or
``timeout_mask`` gets NaN forces and a :class:`ForceStatus` flag. With ``strict=True`` such a
row raises :class:`InvalidCounts` instead. Counts outside the range seen during
calibration (by more than 10 % of its span) give a number with the ``OUT_OF_RANGE`` flag:
an extrapolation, to be trusted less. Wrong shapes always raise ``ValueError``.
"""
from __future__ import annotations

import enum
import json
import threading
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from ...badfile import BadFileError
from ...protocol import INT24_MAX, INT24_MIN
from ..nets.onnx_io import open_session


class ForceStatus(enum.IntFlag):
    """Why an estimate is missing (NaN) or doubtful (``OUT_OF_RANGE``); 0 is OK."""

    OK = 0
    TIMEOUT = 1
    """A channel's chip did not answer (frame's timeout_mask): no estimate."""
    SATURATED = 2
    """A channel at the ADC's limit (frame's saturation_mask, or the count itself)."""
    NONFINITE = 4
    """A NaN or infinite count: no estimate."""
    OUT_OF_RANGE = 8
    """Counts beyond the calibrated range: the estimate is an extrapolation."""

    @property
    def usable(self) -> bool:
        return not (self & (ForceStatus.TIMEOUT | ForceStatus.SATURATED
                            | ForceStatus.NONFINITE))


INVALID = ForceStatus.TIMEOUT | ForceStatus.SATURATED | ForceStatus.NONFINITE


class InvalidCounts(ValueError):
    """Raised by ``strict`` estimates on a timed-out, saturated or non-finite input."""

    def __init__(self, message: str, status: np.ndarray | int) -> None:
        super().__init__(message)
        self.status = status


class FrameForce(NamedTuple):
    """The force of one frame: NaN when ``status`` has TIMEOUT, SATURATED or NONFINITE."""

    fx: float
    fy: float
    status: ForceStatus
    device_time_us: int
    host_time: float

    @property
    def ok(self) -> bool:
        """An estimate exists (it may still be flagged OUT_OF_RANGE)."""
        return self.status.usable

    @property
    def magnitude(self) -> float:
        return float(np.hypot(self.fx, self.fy))


def _meta_value(v: str) -> Any:
    try:
        return json.loads(v)
    except (ValueError, TypeError):
        return v


class ForceModel:
    """A calibrated force model (ONNX) run with onnxruntime on one CPU thread.

    ``path``: the ``force.onnx`` (or any ``force_<model>.onnx``) written by
    ``fingertip calibrate fit``. ``gain``: the gain your device streams at, when it differs
    from the one of the calibration (counts are rescaled: HX711 counts scale with the gain).
    Calling the object is :meth:`estimate`, so it can be a recorder's ``force_model``.
    """

    def __init__(self, path: str | Path, *, gain: int | None = None, threads: int = 1,
                 range_margin: float = 0.1) -> None:
        if gain is not None and gain not in (128, 64, 32):
            raise ValueError(f"gain must be 128, 64 or 32 (the HX711's), not {gain!r}")
        if not 0 <= range_margin < float("inf"):
            raise ValueError(f"range_margin must be a fraction >= 0, not {range_margin!r}")
        self._session = open_session(path, threads, what="force model")
        self.path = Path(path)
        self._local = threading.local()
        inp = self._session.get_inputs()[0]
        self._input = inp.name
        self._output = self._session.get_outputs()[0].name
        raw = dict(self._session.get_modelmeta().custom_metadata_map)
        self.metadata: dict[str, Any] = {k: _meta_value(v) for k, v in raw.items()}
        m = self.metadata
        shape_c = inp.shape[-1] if isinstance(inp.shape[-1], int) else None
        self.channels = int(m.get("channels", shape_c or 4))
        kind = m.get("fingertip_model", "force")
        if kind != "force" or str(m.get("format", "")).startswith("fingertip-vibration"):
            raise BadFileError(f"{path} is not a force model (it is a "
                               f"{m.get('kind') or kind or 'different'} model)", path)
        if shape_c is not None and shape_c != self.channels:
            raise BadFileError(f"{path}: metadata says {self.channels} channels, the graph "
                               f"takes {shape_c}", path)
        out_c = self._session.get_outputs()[0].shape[-1]
        if isinstance(out_c, int) and out_c != 2:
            raise BadFileError(f"{path} outputs {out_c} values, not (Fx, Fy): not a force "
                               f"model", path)
        self.units = str(m.get("units", "N"))
        self.kind = str(m.get("model", m.get("kind", "unknown")))
        self.rmse_n = float(m["heldout_rmse_n"]) if "heldout_rmse_n" in m else None
        self.train_rmse_n = float(m["train_rmse_n"]) if "train_rmse_n" in m else None
        self.model_gain = int(m.get("counts_gain", 128))
        self.gain = int(gain) if gain else self.model_gain
        self._scale = np.float32(self.model_gain / self.gain)
        lo, hi = m.get("counts_min"), m.get("counts_max")
        if lo is not None and hi is not None:
            lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
            span = hi - lo
            self._range = ((lo - range_margin * span).astype(np.float32),
                           (hi + range_margin * span).astype(np.float32))
        else:
            self._range = None
        self._range_lists = None if self._range is None else \
            (self._range[0].tolist(), self._range[1].tolist())

    def __repr__(self) -> str:
        rm = f", held-out RMSE {self.rmse_n:.3f} {self.units}" if self.rmse_n else ""
        return f"ForceModel({self.path.name}: {self.kind}, {self.channels} channels{rm})"

    # --- core -----------------------------------------------------------------------------

    def _status(self, x: np.ndarray, timeout_mask, saturation_mask) -> np.ndarray:
        """Per row status (uint8) for (N, C) float64 counts as given (before rescaling)."""
        st = np.zeros(len(x), np.uint8)
        fin = np.isfinite(x)
        st[~fin.all(axis=1)] |= np.uint8(ForceStatus.NONFINITE)
        st[(fin & ((x <= INT24_MIN) | (x >= INT24_MAX))).any(axis=1)] |= np.uint8(
            ForceStatus.SATURATED)
        full = (1 << self.channels) - 1
        for mask, flag in ((timeout_mask, ForceStatus.TIMEOUT),
                           (saturation_mask, ForceStatus.SATURATED)):
            if np.any(mask):
                m = np.broadcast_to(np.asarray(mask, np.int64), (len(x),))
                st[(m & full) != 0] |= np.uint8(flag)
        return st

    def estimate(self, counts, *, timeout_mask=0, saturation_mask=0, strict: bool = False,
                 return_status: bool = False):
        """Forces for one frame (``counts`` of length C -> array (2,): fx, fy) or a batch
        ((N, C) -> (N, 2)). Counts are tared HX711 counts as the device streams them.

        ``timeout_mask``/``saturation_mask``: per-channel bits (an int, or one per row).
        Invalid rows give NaN (or raise :class:`InvalidCounts` with ``strict``). With
        ``return_status`` the result is ``(forces, status)``, status a :class:`ForceStatus`
        for one frame and a uint8 array of its values for a batch.
        """
        if np.isscalar(timeout_mask) and np.isscalar(saturation_mask) \
                and not (timeout_mask or saturation_mask):
            one = self._run_one(counts, return_status)
            if one is not None:
                out = one[0].astype(np.float64)  # a copy: the buffer is reused next call
                return (out, one[1]) if return_status else out
        x = np.asarray(counts, dtype=np.float64)
        single = x.ndim == 1
        if single:
            x = x[None, :]
        if x.ndim != 2 or x.shape[1] != self.channels:
            raise ValueError(f"{self.path.name} takes {self.channels} channels per frame, got "
                             f"an array of shape {np.shape(counts)}")
        st = self._status(x, timeout_mask, saturation_mask)
        bad = (st & np.uint8(INVALID)) != 0
        if strict and bad.any():
            first = int(np.flatnonzero(bad)[0])
            raise InvalidCounts(
                f"{int(bad.sum())} frame(s) cannot be estimated (first: row {first}, "
                f"{ForceStatus(int(st[first])).name}, counts {x[first].tolist()})",
                ForceStatus(int(st[first])) if single else st)
        xf = x.astype(np.float32)
        if self._scale != 1:
            xf *= self._scale
        if bad.any():
            xf[bad] = 0.0           # keep the graph away from NaN/Inf; the rows become NaN
        if self._range is not None:
            lo, hi = self._range
            st[((xf < lo) | (xf > hi)).any(axis=1) & ~bad] |= np.uint8(ForceStatus.OUT_OF_RANGE)
        out = self._session.run([self._output], {self._input: xf})[0].astype(np.float64)
        if bad.any():
            out[bad] = np.nan
        if single:
            return (out[0], ForceStatus(int(st[0]))) if return_status else out[0]
        return (out, st) if return_status else out

    __call__ = estimate

    def estimate_xyz(self, counts) -> tuple[float, float, float]:
        """``(fx, fy, 0.0)`` of one frame's counts as Python floats, the force vector a
        ``WrenchStamped`` carries (NaN when the frame cannot be estimated): what a
        publisher or recorder needs per frame, without an array to convert."""
        one = self._run_one(counts, False)
        if one is None:
            f = self.estimate(counts)
            return float(f[0]), float(f[1]), 0.0
        fx, fy = one[0].tolist()
        return fx, fy, 0.0

    def _run_one(self, counts, want_status: bool) -> tuple[np.ndarray, ForceStatus] | None:
        """The common case, one valid frame without masks, in plain Python (about 2 us of
        overhead on top of onnxruntime instead of 30): ``(output row, status)``, the row a
        view of a buffer the next call overwrites; None: take the general path. The range
        is checked only when the status is wanted."""
        if isinstance(counts, np.ndarray):
            if counts.ndim != 1:
                return None
        elif not isinstance(counts, (list, tuple)):
            return None
        if len(counts) != self.channels:
            return None
        for v in counts:
            if not INT24_MIN < v < INT24_MAX:     # also False for NaN
                return None
        # One preallocated input/output pair bound to the session per thread: a plain
        # session.run costs ~30 us more per call when frames come every few ms (cold caches,
        # allocations); the binding is reused, and each thread has its own.
        tl = self._local
        bind = getattr(tl, "binding", None)
        if bind is None:
            bind = self._new_binding(tl)
        buf = tl.x
        buf[0, :] = counts
        if self._scale != 1:
            buf *= self._scale
        st = ForceStatus.OK
        if want_status and self._range is not None:
            lo, hi = self._range_lists
            for v, a, b in zip(buf[0].tolist(), lo, hi, strict=True):
                if v < a or v > b:
                    st = ForceStatus.OUT_OF_RANGE
                    break
        self._session.run_with_iobinding(bind)
        return tl.y[0], st

    def _new_binding(self, tl):
        import onnxruntime as ort

        tl.x = np.zeros((1, self.channels), np.float32)
        tl.y = np.zeros((1, 2), np.float32)
        bind = self._session.io_binding()
        bind.bind_ortvalue_input(self._input, ort.OrtValue.ortvalue_from_numpy(tl.x))
        bind.bind_ortvalue_output(self._output, ort.OrtValue.ortvalue_from_numpy(tl.y))
        tl.binding = bind
        return bind

    def estimate_frame(self, frame, channels: tuple[int, ...] | None = None, *,
                       strict: bool = False) -> FrameForce:
        """The force of a :class:`fingertip.Frame` (or a ``FingerFrame``): its timeout and
        saturation masks are honoured; ``channels`` picks this fingertip's channels of a
        larger device (default: the first C)."""
        frame = getattr(frame, "frame", frame)        # FingerFrame -> Frame
        chans = tuple(range(self.channels)) if channels is None else tuple(channels)
        if len(chans) != self.channels:
            raise ValueError(f"need {self.channels} channels, got {chans}")
        counts = frame.counts
        if max(chans) >= len(counts):
            raise ValueError(f"frame has {len(counts)} channels, asked for {chans}")
        tm = sum(1 << k for k, c in enumerate(chans) if frame.timeout_mask >> c & 1)
        sm = sum(1 << k for k, c in enumerate(chans) if frame.saturation_mask >> c & 1)
        f, st = self.estimate([counts[c] for c in chans], timeout_mask=tm, saturation_mask=sm,
                              strict=strict, return_status=True)
        return FrameForce(float(f[0]), float(f[1]), st, int(frame.device_time_us),
                          float(frame.host_time))

    def estimate_frames(self, frames, channels: tuple[int, ...] | None = None
                        ) -> tuple[np.ndarray, np.ndarray]:
        """A list of frames at once: ((N, 2) forces with NaN rows, (N,) status)."""
        frames = [getattr(f, "frame", f) for f in frames]
        chans = tuple(range(self.channels)) if channels is None else tuple(channels)
        if not frames:
            return np.zeros((0, 2)), np.zeros(0, np.uint8)
        counts = np.array([[f.counts[c] for c in chans] for f in frames], np.float64)

        def sub(mask: int) -> int:
            return sum(1 << k for k, c in enumerate(chans) if mask >> c & 1)

        tm = np.array([sub(f.timeout_mask) for f in frames], np.int64)
        sm = np.array([sub(f.saturation_mask) for f in frames], np.int64)
        return self.estimate(counts, timeout_mask=tm, saturation_mask=sm, return_status=True)
