"""Waiting for a condition that a device's threads make true, with a deadline."""
from __future__ import annotations

import time


def wait_for(pred, timeout=3.0, step=0.01):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if pred():
            return True
        time.sleep(step)
    return False
