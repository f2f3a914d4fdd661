"""Events layer: contact and vibration events detected on force and audio signals."""
from .detect import (
    Event, contact_intervals, heights_at, refine_contacts, rms_envelope, robust_sigma,
    vibration_onsets,
)

__all__ = ["Event", "contact_intervals", "heights_at", "refine_contacts", "rms_envelope",
           "robust_sigma", "vibration_onsets"]
