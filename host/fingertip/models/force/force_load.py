"""Open a force model (``calibrate fit`` / ``calibrate record``'s ONNX file) for a given
fingertip, refusing one that does not belong to it: :func:`force_model_for` is what
``stream``, ``record`` (and the middleware's ``publish``) call with ``--force-model``.

Refused, with the reason: not a force model, another channel count, units other than
newtons, or a device serial that differs from the fingertip's. A gain that differs is not a
reason: the counts are rescaled (HX711 counts scale with the gain).
"""
from __future__ import annotations

import logging
from pathlib import Path

from ...errors import BadArgumentError
from .runtime import ForceModel

log = logging.getLogger(__name__)
UNITS = "N"


class ModelMismatch(BadArgumentError):
    """The model does not fit this fingertip (one line: which field, both values): the
    user's ``--force-model``, exit status 2 (a ValueError)."""


def device_serial(ft) -> str:
    """The USB serial number of the fingertip's Arduino, or "" when unknown (a pty)."""
    if getattr(ft, "serial_number", None):
        return str(ft.serial_number)
    from ...transport import list_ports

    try:
        port = next((p for p in list_ports(include_non_usb=True) if p.device == ft.port), None)
    except Exception:  # listing ports is a convenience here, never a reason to fail
        return ""
    return (port.serial_number or "") if port else ""


def check_model(model: ForceModel, *, channels: int, serial: str = "", gain: int | None = None,
                allow_other_device: bool = False) -> list[str]:
    """Raise :class:`ModelMismatch` when ``model`` does not fit; return warnings."""
    m = model.metadata
    name = model.path.name
    # Another kind of model (a classifier) is already refused by ForceModel itself.
    if model.channels != channels:
        raise ModelMismatch(f"{name} takes {model.channels} channels, this fingertip streams "
                            f"{channels}")
    if model.units != UNITS:
        raise ModelMismatch(f"{name} gives forces in {model.units!r}, not newtons ({UNITS!r})")
    warn = []
    want = str(m.get("device_serial") or "")
    if want and serial and want != serial and not allow_other_device:
        raise ModelMismatch(f"{name} was calibrated on device {want!r}, this fingertip is "
                            f"{serial!r}: every fingertip needs its own calibration "
                            "(--force-model-any-device to use it anyway)")
    if want and not serial:
        warn.append(f"{name} was calibrated on device {want!r}; this fingertip's serial is "
                    "unknown (not a USB port), so that cannot be checked")
    if gain is not None and gain != model.model_gain:
        warn.append(f"{name} was calibrated at gain {model.model_gain}, the device streams at "
                    f"gain {gain}: counts are rescaled")
    return warn


def force_model_for(ft, path: str | Path, *, allow_other_device: bool = False) -> ForceModel:
    """The force model at ``path`` for the open fingertip ``ft``, or :class:`ModelMismatch`
    / FileNotFoundError / ValueError (not an ONNX file) with a clear message."""
    gain = int(ft.info.gain)
    model = ForceModel(path, gain=gain)
    for w in check_model(model, channels=ft.channels, serial=device_serial(ft), gain=gain,
                         allow_other_device=allow_other_device):
        log.warning("%s", w)
    return model


class ForceWindow:
    """Forces of a streaming fingertip kept for the last ``seconds``, to be averaged over any
    window of host time (a classifier's window, for example). Add it with
    ``ft.add_callback(window.add)``."""

    def __init__(self, model: ForceModel, seconds: float = 30.0) -> None:
        from collections import deque

        self.model = model
        self.seconds = seconds
        self._rows: deque = deque()

    def add(self, frame) -> None:
        est = self.model.estimate_frame(frame)
        if est.ok:
            self._rows.append((frame.host_time, est.fx, est.fy))
        while self._rows and self._rows[0][0] < frame.host_time - self.seconds:
            self._rows.popleft()

    def mean(self, t0: float, t1: float) -> tuple[float, float] | None:
        """Mean (Fx, Fy) of the frames stamped in [t0, t1]; None when there are none."""
        sel = [(fx, fy) for t, fx, fy in list(self._rows) if t0 <= t <= t1]
        if not sel:
            return None
        a = sum(s[0] for s in sel) / len(sel)
        b = sum(s[1] for s in sel) / len(sel)
        return a, b
