"""``fingertip check --hand ... | --port P --hand-split 4x4``: the bring-up check of every
finger of a hand, one after the other, each with a report of its own.

On one device split into fingers, each finger is checked on its own channels (the probe
selects them), so a fault is reported on the finger and channel where it is; the fix lines
name the finger's channel (the report's ``device_channels`` maps it to the device's).
"""
from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Callable

from ..errors import BadArgumentError
from ..hand_args import AudioInput, HandSpec, hand_audio_inputs
from .guide import Guide, NoPromptGuide, PromptGuide
from .probe import DeviceProbe
from .results import Report
from .run import run_check

log = logging.getLogger("fingertip")


class FingerGuide:
    """A guide for one finger of a hand: every step names the finger."""

    def __init__(self, guide: Guide, finger: str) -> None:
        self.guide = guide
        self.finger = finger
        self.interactive = guide.interactive
        self.simulated = guide.simulated

    @property
    def acted_at_s(self) -> float | None:
        return getattr(self.guide, "acted_at_s", None)

    def press(self, face: int, label: str) -> bool:
        return self.guide.press(face, f"{self.finger} fingertip's {label}")

    def tap(self, count: int) -> bool:
        if self.guide.interactive:  # the prompts go to stderr, as the guide's own
            print(f"Now the {self.finger} fingertip:", file=sys.stderr, flush=True)
        return self.guide.tap(count)


def check_hand(spec: HandSpec, args: argparse.Namespace,
               progress: Callable[[str], None] | None = None) -> list[Report]:
    """Open the hand and check each finger in turn; one report per finger (in the hand's
    order). ValueError for bad options (a split the device cannot serve, a file as a
    microphone), device errors as the devices raise them."""
    if getattr(args, "virtual", False) or getattr(args, "fault", None):
        raise BadArgumentError("--virtual and --fault check one simulated fingertip, not a hand")
    inputs = {} if args.no_audio else hand_audio_inputs(args, spec.fingers)
    files = [a.device for a in inputs.values() if a.is_file]
    if files:
        raise BadArgumentError(f"--hand-audio: {files[0]} is a file; the check records live taps "
                         "from a sound card")
    if args.audio_device is not None:
        raise BadArgumentError("a hand's microphones are given with --hand-audio, not "
                         "--audio-device")
    if not inputs and not args.no_audio:
        log.warning("piezos not checked: give the fingers' microphones with --hand-audio")
    guide: Guide = NoPromptGuide() if args.no_prompt else PromptGuide()
    reports = []
    with spec.build() as hand:  # refuses a split the device's channel count cannot serve
        for finger in hand.fingers:
            say = None if progress is None else (lambda m, f=finger: progress(f"{f}: {m}"))
            probe = DeviceProbe(hand.device(finger), hand.channels_of(finger), finger)
            audio = _audio(inputs.get(finger), probe)
            report = run_check(probe, FingerGuide(guide, finger), audio, progress=say)
            report.device["finger"] = finger
            reports.append(report)
    return reports


def _audio(inp: AudioInput | None, probe: DeviceProbe):
    if inp is None:
        return None
    from .audio_capture import SoundCardAudio

    return SoundCardAudio(inp.card, probe, channel=inp.channel, channels=inp.channels)
