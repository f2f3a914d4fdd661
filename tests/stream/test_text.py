"""A frame as a line or a JSON object, with its force when a model gives one."""
from __future__ import annotations

import json
import math

from fingertip import Frame
from fingertip.models.force.runtime import FrameForce, ForceStatus
from fingertip.stream.text import force_fields, force_text, frame_json, frame_line


def test_a_frame_as_json_and_as_a_line():
    f = Frame(7, 2_500_000, 1.5, 1.6, (1, -2, 3, 4), timeout_mask=0b10)
    assert json.loads(frame_json(f, finger="index")) == {
        "finger": "index", "seq": 7, "device_time_us": 2_500_000, "host_time": 1.5,
        "counts": [1, -2, 3, 4], "timeout_mask": 2, "saturation_mask": 0}
    assert frame_line(f) == ("    7     2.500000         1        -2         3         4"
                             "  timeout=0x2 sat=0x0")
    assert frame_line(Frame(1, 0, 0.0, 0.0, (5,))).endswith("        5")


def test_a_force_as_fields_and_text():
    ok = FrameForce(1.25, -0.5, ForceStatus.OK, 0, 0.0)
    far = FrameForce(1.25, -0.5, ForceStatus.OUT_OF_RANGE, 0, 0.0)
    none = FrameForce(math.nan, math.nan, ForceStatus.TIMEOUT, 0, 0.0)
    assert force_fields(None) == {}
    assert force_fields(ok) == {"force_n": [1.25, -0.5], "force_status": 0}
    assert force_fields(none) == {"force_n": None, "force_status": 1}
    assert force_text(ok) == "  Fx  +1.250 Fy  -0.500 N"
    assert force_text(far).endswith("N (extrapolated)")
    assert force_text(none).startswith("  force: none (")
