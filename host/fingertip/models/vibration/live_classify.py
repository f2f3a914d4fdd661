"""Running a trained vibration classifier on one source, the way ``fingertip classify``
does: a recording file or a live audio source (a sound card, the card paired with a
fingertip's serial port, a simulation), each prediction handed to a callback as it comes,
optionally stopping at the first confident answer; and the fingertip whose forces go with
the predictions (``--force-model``)."""
from __future__ import annotations

import logging
import os
from collections.abc import Callable
from typing import Any

from ...audio import AudioSource, SoundDeviceSource
from ...device import Fingertip, FingertipError
from ...device.pairing import sound_card_for_port
from ...errors import BadArgumentError
from .classify import Classification, Prediction, VibrationClassifier
from ..force.force_load import ForceWindow, ModelMismatch, force_model_for

log = logging.getLogger(__name__)


class ForceModelRefused(BadArgumentError):
    """A ``--force-model`` that does not fit the fingertip, or could not be read (the user's
    option: exit status 2; a ValueError)."""


def decided(p: Prediction, threshold: float) -> bool:
    """Whether the running probability (or, before any, this window's) reaches
    ``threshold``."""
    run = p.running or p.probabilities
    return max(run.values()) >= threshold


def sound_card_source(audio: str | None, port: str | None, samplerate: float,
                      channel: int = 0) -> SoundDeviceSource:
    """The sound card ``audio`` (an index or part of its name) or, with ``port``, the card
    on the same USB hub as the fingertip on that serial port, opened with enough inputs to
    read ``channel``."""
    device: int | str | None = audio
    if port is not None:
        device = sound_card_for_port(port)
    elif audio is not None and audio.isdigit():
        device = int(audio)
    return SoundDeviceSource(device, samplerate, channels=channel + 1, dtype="float32")


def open_force_window(port: str, path: str) -> tuple[ForceWindow, Fingertip]:
    """The fingertip on ``port`` streaming into a :class:`ForceWindow` of the force model
    at ``path`` (checked against the fingertip). The caller closes the fingertip. Raises the
    device's errors when it cannot be opened or started, and :class:`ForceModelRefused`
    when the model does not fit it (the fingertip is then closed)."""
    ft = Fingertip(port).open()
    try:
        window = ForceWindow(force_model_for(ft, path))
        ft.add_callback(window.add)
        ft.start()
    except (ModelMismatch, FileNotFoundError, ValueError) as e:
        ft.close()
        raise ForceModelRefused(str(e)) from e
    except FingertipError:
        ft.close()
        raise
    return window, ft


def run_classification(clf: VibrationClassifier, source: str | os.PathLike | AudioSource, *,
                       on_prediction: Callable[[Prediction], Any],
                       rate: float | None = None, duration: float | None = None,
                       channel: int = 0, decide_at: float | None = None) -> Classification:
    """Classify ``source`` with ``clf``, calling ``on_prediction`` with each prediction in
    time order and stopping after the first one :func:`decided` at ``decide_at``.

    A file path is classified whole (``rate``: the rate of a CSV that does not state its
    own) and its full :class:`Classification` is returned, so a decision is read from every
    window. A live source is read until ``duration`` seconds of audio, its end, a decision
    or Ctrl-C, then stopped; the result holds the predictions made until then.
    """
    if isinstance(source, (str, os.PathLike)):
        result = clf.classify(source, rate=rate)
        for p in result.predictions:
            on_prediction(p)
            if decide_at is not None and decided(p, decide_at):
                break
        return result
    preds: list[Prediction] = []
    try:
        for p in clf.stream(source, duration=duration, channel=channel):
            preds.append(p)
            on_prediction(p)
            if decide_at is not None and decided(p, decide_at):
                break
    except KeyboardInterrupt:  # the user ends a live stream: keep what came so far
        pass
    finally:
        source.stop()
    return Classification(preds, clf.classes, clf.novelty_threshold)
