"""What a recording carries, as ROS 2 CDR messages: frames, forces, audio, events and device
information, from the items the :class:`~fingertip.record.recorder.Recorder` queues.

A queue item is a tuple whose first field says its kind and second the fingertip's name:
``("raw", name, frame)``, ``("wrench", name, host_time, force, torque)``,
``("audio", name, host_time, first_index, frames, channels, rate, host_rate, lost_before,
encoding, data)``, ``("event", name, host_time, kind, value, detail)``,
``("info", name, host_time, text)``, ``("encoded", name, topic_kind, log_ns, data)``.
The network publishers use the same conversions (:func:`frame_message`,
:func:`audio_payload`, :func:`device_info`).
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import asdict
from typing import Any

import numpy as np

from ..device import Frame
from ..protocol import message_to_dict
from . import schemas as S
from .timebase import TimeBase

ForceModel = Callable[[Sequence[int]], Sequence[float]]
"""Raw counts of one frame -> ``(fx, fy)`` or ``(fx, fy, fz)`` in newtons."""

Message = tuple[str, str, int, bytes, "dict[str, str] | None"]
"""``(name, topic kind, log time in Unix ns, CDR bytes, channel metadata)``."""


def encode_item(item: tuple, tb: TimeBase, *, force_model: ForceModel | None = None,
                audio_metadata: dict[str, str] | None = None,
                on_model_error: Callable[[str, Exception], None] | None = None
                ) -> list[Message]:
    """The messages of one queue item. ``force_model`` turns a frame's counts into its
    wrench too; a model failing on one frame is reported to ``on_model_error`` and the frame
    is written without it. Bad values raise ValueError, TypeError, OverflowError or
    struct.error."""
    kind, name = item[0], item[1]
    if kind == "raw":
        f: Frame = item[2]
        raw = frame_message(name, f, tb)
        ns = raw.stamp_ns
        out: list[Message] = [(name, "raw", ns, S.encode_raw(raw), None)]
        if force_model is not None:
            try:
                force = xyz(force_model(f.counts))
            except Exception as e:  # a model failing on one frame must not stop recording
                if on_model_error is not None:
                    on_model_error(name, e)
            else:
                out.append((name, "wrench", ns, S.encode_wrench(
                    S.WrenchMsg(ns, name, force)), None))
        return out
    if kind == "wrench":
        ns = tb.to_ns(item[2])
        return [(name, "wrench", ns, S.encode_wrench(S.WrenchMsg(ns, name, item[3],
                                                                 item[4])), None)]
    if kind == "audio":
        (_, _, host_time, first_index, frames, channels, rate, host_rate, lost, enc,
         data) = item
        ns = tb.to_ns(host_time)
        msg = S.AudioMsg(ns, name, first_index, frames, channels, float(rate),
                         float(host_rate), lost, enc, data)
        return [(name, "audio", ns, S.encode_audio(msg), audio_metadata)]
    if kind == "event":
        ns = tb.to_ns(item[2])
        return [(name, "events", ns, S.encode_event(S.EventMsg(ns, name, item[3],
                                                               item[4], item[5])), None)]
    if kind == "encoded":
        return [(name, item[2], item[3], item[4], audio_metadata)]
    if kind == "info":
        ns = tb.to_ns(item[2])
        return [(name, "info", ns, S.encode_string(item[3]), None)]
    raise ValueError(f"unknown item {kind!r}")


def item_topic(item: tuple) -> str:
    """The topic a queue item is written on (for counting it when it is lost)."""
    kind = {"event": "events", "encoded": item[2]}.get(item[0], item[0])
    return S.topic(item[1], kind)


def device_info(fingertip: Any, name: str) -> dict[str, Any]:
    """What ``/fingertip/<name>/info`` says about a fingertip (or any frame source)."""
    info: dict[str, Any] = {"name": name, "port": getattr(fingertip, "port", ""),
                            "serial_number": getattr(fingertip, "serial_number", None)}
    try:
        info["info"] = message_to_dict(fingertip.info)
    except Exception:  # not open yet (or a source without INFO): nothing to say
        pass
    settings = getattr(fingertip, "settings", None)
    if settings is not None:
        info["settings"] = asdict(settings)
    return info


def frame_message(name: str, f: Frame, tb: TimeBase) -> S.RawMsg:
    """A frame as recordings (and the network publishers) carry it: stamped with its
    clock-fitted host time (its arrival time when the fit has none yet)."""
    t = f.host_time if math.isfinite(f.host_time) else f.arrival_time
    return S.RawMsg(tb.to_ns(t), name, f.seq & 0xFFFFFFFF, f.device_time_us,
                    tb.to_ns(f.arrival_time), tuple(f.counts), f.timeout_mask,
                    f.saturation_mask)


def audio_payload(samples: Any) -> tuple[str, bytes] | None:
    """Audio samples -> ``(encoding, interleaved little-endian bytes)``, or None when their
    dtype cannot be carried (not int16, int32 or float32)."""
    a = np.asarray(samples)
    # Looked up by (kind, size): dtype.name is a Python-level property, slow per chunk.
    enc_le = _AUDIO_LE.get((a.dtype.kind, a.dtype.itemsize))
    if enc_le is None:
        return None
    enc, le = enc_le
    return enc, np.ascontiguousarray(a, dtype=le).tobytes()


_AUDIO_LE = {(np.dtype(n).kind, np.dtype(n).itemsize): (enc, np.dtype(n).newbyteorder("<"))
             for n, enc in S.AUDIO_ENCODINGS.items()}


def xyz(v: Sequence[float]) -> tuple[float, float, float]:
    vals = [float(x) for x in v]
    if not 2 <= len(vals) <= 3:
        raise ValueError(f"expected (x, y) or (x, y, z), got {len(vals)} values")
    if len(vals) == 2:
        vals.append(0.0)
    return vals[0], vals[1], vals[2]
