"""Waiting for a condition that a device's threads make true, with a deadline."""
from __future__ import annotations

import time

PATIENCE = 20.0
"""How long a wait for something that must happen may take on a busy host: a test worker
beside busy loops can get under a fifth of a core (one fingertip delivered fewer than 10
frames in 2 s so). Each wait ends as soon as its condition holds, and a stuck thread still
fails it. Tests that assert how soon something happens are marked ``realtime`` instead."""


def wait_for(pred, timeout=3.0, step=0.01):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if pred():
            return True
        time.sleep(step)
    return False
