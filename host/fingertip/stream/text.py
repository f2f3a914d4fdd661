"""How a frame is shown: one JSON object, or one line of text (``fingertip stream`` and
``fingertip replay``), with the force of a calibrated fingertip when there is one."""
from __future__ import annotations

import json
from typing import Any


def frame_json(f: Any, **extra: Any) -> str:
    """One JSON object per frame (``extra`` first, e.g. ``finger=...``)."""
    return json.dumps({**extra, "seq": f.seq, "device_time_us": f.device_time_us,
                       "host_time": f.host_time, "counts": f.counts,
                       "timeout_mask": f.timeout_mask, "saturation_mask": f.saturation_mask})


def frame_line(f: Any) -> str:
    """seq, device time (s), the counts, and the masks when a channel is not ok."""
    return (f"{f.seq:5d} {f.device_time_us / 1e6:12.6f} " + " ".join(f"{c:9d}" for c in f.counts)
            + ("" if f.ok else f"  timeout={f.timeout_mask:#x} sat={f.saturation_mask:#x}"))


def force_fields(est: Any) -> dict:
    """The JSON fields of a force estimate (none without a model)."""
    if est is None:
        return {}
    return {"force_n": [est.fx, est.fy] if est.ok else None,
            "force_status": int(est.status)}


def force_text(est: Any) -> str:
    """``  Fx +1.234 Fy -0.567 N`` (or why there is no estimate)."""
    if not est.ok:
        return f"  force: none ({est.status!r})"
    flag = " (extrapolated)" if est.status else ""
    return f"  Fx {est.fx:+7.3f} Fy {est.fy:+7.3f} N{flag}"
