"""What ``fingertip publish`` publishes, opened: the transport, the fingertips (serial ports,
USB serial numbers, a replay, a hand's fingers), their names, the microphone, the force model
checked against the devices and the vibration classifiers. Each opened thing is closed by the
caller's :class:`contextlib.ExitStack` (or its own ``stop``/``close``)."""
from __future__ import annotations

import contextlib
import logging
from collections.abc import Sequence
from typing import Any

from ..audio import AudioSource, FileSource, SimulatedSource, SoundDeviceSource
from ..device import Fingertip, SharedReader
from ..device.finger import FingerView
from ..errors import BadArgumentError
from ..hand_args import HandSpec
from ..models.force.force_load import check_model, device_serial, force_model_for
from . import TRANSPORTS

log = logging.getLogger("fingertip")


def make_transport(kind: str, zenoh_connect: Sequence[str] | None = None,
                   zenoh_listen: Sequence[str] | None = None) -> Any:
    """The network transport ``kind`` (one of :data:`~fingertip.network.TRANSPORTS`),
    started; its library is imported only here (a missing extra raises
    :class:`~fingertip.network.ExtraMissing`)."""
    if kind not in TRANSPORTS:
        raise BadArgumentError(f"--transport is one of {', '.join(TRANSPORTS)}, not {kind!r}")
    if kind == "dds":
        from .dds import DdsTransport

        return DdsTransport()
    if kind == "zenoh":
        from .zenoh import ZenohTransport

        return ZenohTransport(zenoh_connect, zenoh_listen)
    from .lsl import LslTransport

    return LslTransport()


def publish_names(name: str | None, n: int) -> list[str]:
    """``--name`` (comma-separated) -> one checked topic name per fingertip; by default
    ``fingertip`` for one, ``finger0, finger1...`` for several. ValueError when the count
    or a name is wrong (a BadArgumentError)."""
    from ..record.schemas import check_name

    if name is not None:  # an empty --name is refused by check_name, not taken as none
        names = [s.strip() for s in name.split(",")]
    else:
        names = ["fingertip"] if n == 1 else [f"finger{i}" for i in range(n)]
    if len(names) != n:
        raise BadArgumentError(f"--name lists {len(names)} names for {n} fingertips")
    if len(set(names)) != n:
        raise BadArgumentError("--name: every fingertip needs its own name")
    return [check_name(s) for s in names]


def open_replay(path: str, name: str | None, stack: contextlib.ExitStack, *,
                speed: float = 1.0, rebase: bool = True) -> Any:
    """A recording replayed as a fingertip (``name``: which of its fingertips, None for the
    first); ``rebase=False`` keeps the recording's own stamps."""
    from ..record.replay import Replay

    rp = Replay(path, name, speed=speed, rebase=rebase)
    stack.enter_context(rp)
    return rp


def open_fingertips(ports: Sequence[str], serials: Sequence[str],
                    stack: contextlib.ExitStack) -> list[Fingertip]:
    """The fingertips on ``ports`` and with USB ``serials``, opened, all read on one thread
    and handing frames to callbacks only (no queue: the feed takes them by callback)."""
    reader = SharedReader()
    stack.callback(reader.close)
    fts = [stack.enter_context(Fingertip(p, queue_size=0, reader=reader).open())
           for p in ports]
    fts += [stack.enter_context(Fingertip(serial_number=s, queue_size=0, reader=reader).open())
            for s in serials]
    return fts


def open_hand(spec: HandSpec, stack: contextlib.ExitStack) -> list[Any]:
    """The fingers of a hand, one frame source per finger (see
    :func:`fingertip.network.hand.open_fingers`)."""
    from .hand import open_fingers

    return open_fingers(spec, stack)


def audio_source(audio: str | None, audio_file: str | None, virtual_audio: bool,
                 rate: float, ports: Sequence[str] | None = None) -> AudioSource | None:
    """The (first) fingertip's microphone: a sound card (index, part of its name, or
    ``paired``: the card on the same USB hub as the first of ``ports``), a WAV file played in
    real time, a simulated 440 Hz tone, or None. Not started."""
    if audio is not None:
        if audio == "paired":  # the card behind the same USB hub as the fingertip
            from ..device.pairing import sound_card_for_port

            if not ports:
                raise BadArgumentError("--audio paired needs --port (the sound card is found "
                                 "next to it on the USB hub)")
            dev: int | str = sound_card_for_port(ports[0])
        else:
            dev = int(audio) if audio.isdigit() else audio
        return SoundDeviceSource(dev, rate, channels=1, dtype="int16")
    if audio_file:
        return FileSource(audio_file, realtime=True)
    if virtual_audio:
        import numpy as np

        def tone(t):
            return 0.25 * np.sin(2 * np.pi * 440.0 * t)
        return SimulatedSource(tone, rate, dtype="int16", blocksize=441)
    return None


def checked_force_model(path: str, sources: Sequence[Any], model: Any) -> Any:
    """``--force-model FORCE.onnx`` checked against every live fingertip (channels, units,
    device serial; refused with the reason), as ``stream`` and ``record`` do. A replay's
    frames are taken as they are."""
    live = [s for s in sources if isinstance(s, (Fingertip, FingerView))]
    if not live:
        return model
    model = force_model_for(live[0], path)
    for ft in live[1:]:
        for w in check_model(model, channels=ft.channels, serial=device_serial(ft),
                             gain=int(ft.info.gain)):
            log.warning("%s", w)
    return model


def load_classifiers(material_model: str | None, shake_model: str | None
                     ) -> list[tuple[str, Any]]:
    """``(kind, VibrationClassifier)`` for --material-model and --shake-model."""
    out = []
    for kind, path in (("material", material_model), ("shake", shake_model)):
        if path:
            from ..models.vibration.classify import VibrationClassifier

            out.append((kind, VibrationClassifier(path, kind=kind)))
    return out
