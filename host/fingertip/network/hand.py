"""A hand on the network (``fingertip publish --hand ... | --port P --hand-split 4x4``):
every finger is published as a fingertip of its own (``/fingertip/<finger>/raw``, ``wrench``,
``audio``, ``events``, ``info``), from one device per finger or from one 16-channel device
split into fingers, with each finger's microphone on its own audio topic."""
from __future__ import annotations

import argparse
import contextlib
import logging
from collections.abc import Callable, Sequence
from typing import Any

from ..hand_args import HandSpec

log = logging.getLogger(__name__)


def hand_conflict(args: argparse.Namespace, spec: HandSpec | None) -> str | None:
    """Why the options cannot publish this hand (one line), or None."""
    if spec is None:
        return None
    if spec.groups is not None and spec.port is None and spec.serial is None:
        return "--hand-split splits one device: give it with --port or --serial"
    if args.name:
        return "a hand's topics are named after its fingers: use --finger-names (or the " \
               "names in --hand), not --name"
    if args.audio is not None or args.audio_file or args.virtual_audio:
        return "a hand's microphones are given with --hand-audio"
    if args.material_model or args.shake_model:
        return "--material-model and --shake-model classify one fingertip's microphone; " \
               "they are not run on a hand"
    return None


def open_fingers(spec: HandSpec, stack: contextlib.ExitStack) -> list[Any]:
    """Open the hand (refusing a split that names channels the device does not have) and
    return one frame source per finger (:class:`~fingertip.device.finger.FingerView`),
    closed with ``stack``. As for single fingertips (``publish_sources.open_fingertips``),
    all its devices are read on one thread and nothing queues frames: the feed takes them
    by callback, so a queue would only count overruns of frames nobody reads."""
    from ..device import SharedReader
    from ..device.finger import finger_views

    reader = SharedReader()
    stack.callback(reader.close)  # after the hand's devices are closed (the stack unwinds)
    hand = stack.enter_context(spec.build(callbacks_only=True, reader=reader))
    return finger_views(hand)


def pump_hand_audio(feed, transport, audio: Sequence[tuple[Any, list[str]]],
                    also: Callable[[str, Any], Any] | None = None) -> None:
    """Publish each finger's microphone on its own audio topic: ``audio`` as given by
    :func:`~fingertip.hand_args.hand_audio_from_args` (one multi-input source, or one
    source per finger)."""
    from ..record.schemas import AUDIO_ENCODINGS

    for source, names in audio:
        if hasattr(transport, "declare_audio"):
            for name in names:
                transport.declare_audio(name, source.sample_rate, 1,
                                        AUDIO_ENCODINGS[source.dtype.name])
        if len(names) == 1 and source.channels == 1:
            feed.pump_audio(source, names[0], also=also)
        else:
            feed.pump_audio_split(source, names, also=also)
