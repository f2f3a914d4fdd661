"""A hand on the command line: ``--hand index=PORT,middle=PORT,...`` (one device per finger)
or ``--port PORT --hand-split 4x4`` (one 16-channel device, e.g. the pcb/hand shield, split
into four fingertips), and the fingers' microphones with ``--hand-audio``.

Shared by every command that talks to a hand (``stream``, ``record``, ``check``,
``publish``): :func:`add_hand_args` adds the options, :func:`hand_from_args` builds the
:class:`~fingertip.device.Hand`, :func:`hand_audio_from_args` the audio sources. The parsers
raise :class:`~fingertip.errors.BadArgumentError` (a ValueError) with one line that says what
is wrong: exit status 2.
"""
from __future__ import annotations

import argparse
import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from .errors import BadArgumentError

if TYPE_CHECKING:  # the parsers stay light: `fingertip --help` loads no device code
    from .device import Hand

SPLIT_RE = re.compile(r"^\s*(\d+)\s*[xX]\s*(\d+)\s*$")
NAME_RE = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
DEFAULT_FINGERS = ("f0", "f1", "f2", "f3", "f4", "f5", "f6", "f7")


def _check_name(name: str, what: str) -> str:
    if not NAME_RE.match(name):
        raise BadArgumentError(f"{what}: finger name {name!r} must start with a letter and hold "
                         "only letters, digits and _")
    return name


def parse_assignments(text: str, what: str = "--hand") -> dict[str, str]:
    """``"index=/dev/ttyACM0,middle=/dev/ttyACM1"`` -> ``{"index": "/dev/ttyACM0", ...}``
    (order kept). Names must be unique and make topic names."""
    out: dict[str, str] = {}
    for item in text.split(","):
        item = item.strip()
        if not item:
            raise BadArgumentError(f"{what}: empty entry in {text!r} (expected NAME=VALUE,...)")
        name, sep, value = item.partition("=")
        name, value = name.strip(), value.strip()
        if not sep or not value:
            raise BadArgumentError(f"{what}: {item!r} is not NAME=VALUE")
        _check_name(name, what)
        if name in out:
            raise BadArgumentError(f"{what}: finger {name!r} is given twice")
        out[name] = value
    return out


def parse_split(text: str, names: Sequence[str] | None = None) -> dict[str, tuple[int, ...]]:
    """``"4x4"`` -> four fingers of four consecutive channels: ``{"f0": (0, 1, 2, 3), ...}``
    (or under ``names``). ``FxC``: F fingers of C channels, F * C <= 16."""
    m = SPLIT_RE.match(text)
    if not m:
        raise BadArgumentError(f"--hand-split: {text!r} is not FINGERSxCHANNELS (e.g. 4x4)")
    fingers, per = int(m.group(1)), int(m.group(2))
    if fingers < 1 or per < 1 or fingers * per > 16:
        raise BadArgumentError(f"--hand-split: {text!r} needs 1..16 channels in all "
                         f"({fingers} x {per} = {fingers * per})")
    if names is None:
        if fingers > len(DEFAULT_FINGERS):
            raise BadArgumentError(f"--hand-split: name the {fingers} fingers with --finger-names")
        names = DEFAULT_FINGERS[:fingers]
    names = [_check_name(n, "--finger-names") for n in names]
    if len(names) != fingers:
        raise BadArgumentError(f"--finger-names: {len(names)} names for {fingers} fingers")
    if len(set(names)) != len(names):
        raise BadArgumentError("--finger-names: a name is given twice")
    return {n: tuple(range(k * per, (k + 1) * per)) for k, n in enumerate(names)}


def parse_names(text: str | None) -> list[str] | None:
    return None if text is None else [n.strip() for n in text.split(",")]


def add_hand_args(p: argparse.ArgumentParser, group=None) -> None:
    """Add ``--hand`` (to ``group``, the command's mutually exclusive device group, when
    given), ``--hand-split``, ``--finger-names`` and ``--hand-audio``."""
    (group or p).add_argument(
        "--hand", metavar="NAME=PORT,...",
        help="a hand of one device per finger, e.g. index=/dev/ttyACM0,middle=/dev/ttyACM1")
    p.add_argument("--hand-split", metavar="FxC",
                   help="split the device of --port/--serial into F fingers of C consecutive "
                        "channels, e.g. 4x4 for the 16-channel hand shield")
    p.add_argument("--finger-names", metavar="A,B,...",
                   help="names of the --hand-split fingers (default f0,f1,...)")
    p.add_argument("--hand-audio", metavar="DEVICE | NAME=DEVICE,...",
                   help="the fingers' microphones: one multi-channel sound card (input k -> "
                        "k-th finger) or one card per finger; a .wav/.flac file stands in "
                        "for a card (played in real time)")


@dataclass
class HandSpec:
    """What the options ask for: fingers -> port (one device each) or -> channels of one
    device (``port`` / ``serial``)."""

    ports: dict[str, str] | None = None
    groups: dict[str, tuple[int, ...]] | None = None
    port: str | None = None
    serial: str | None = None

    @property
    def fingers(self) -> list[str]:
        return list(self.ports or self.groups or {})

    def build(self, *, callbacks_only: bool = False, **kw) -> Hand:
        """The (unopened) :class:`Hand`; ``kw`` go to each :class:`Fingertip` (e.g.
        ``reader=SharedReader()``: every device read on one thread). ``callbacks_only``:
        neither the hand nor its devices queue frames, for consumers that take them by
        callback (``queue_size=0`` on both)."""
        from .device import Fingertip, Hand

        if callbacks_only:
            kw["queue_size"] = 0
        hand_queue = {"queue_size": 0} if callbacks_only else {}
        if self.ports is not None:
            return Hand({n: Fingertip(p, name=n, **kw) for n, p in self.ports.items()},
                        **hand_queue)
        dev = (Fingertip(serial_number=self.serial, name="hand", **kw) if self.serial
               else Fingertip(self.port, name="hand", **kw))
        return Hand.split(dev, self.groups or {}, **hand_queue)


def hand_spec_from_args(args: argparse.Namespace) -> HandSpec | None:
    """The hand the options describe, or None for a single fingertip. ValueError on bad
    options."""
    hand = getattr(args, "hand", None)
    split = getattr(args, "hand_split", None)
    names = parse_names(getattr(args, "finger_names", None))
    if hand is not None:
        if split is not None:
            raise BadArgumentError("--hand-split splits one device (--port/--serial); with --hand "
                             "each finger has its own device")
        if names is not None:
            raise BadArgumentError("--finger-names names the --hand-split fingers; --hand names "
                             "its fingers itself")
        return HandSpec(ports=parse_assignments(hand))
    if split is None:
        if names is not None or getattr(args, "hand_audio", None) is not None:
            raise BadArgumentError("--finger-names and --hand-audio need --hand or --hand-split")
        return None
    return HandSpec(groups=parse_split(split, names), port=_one(args, "port"),
                    serial=_one(args, "serial"))


def _one(args: argparse.Namespace, what: str) -> str | None:
    """``--port``/``--serial`` of the device to split: commands that take several (``check``,
    ``publish``: repeatable options) must give exactly one with ``--hand-split``."""
    value = getattr(args, what, None)
    if not isinstance(value, list):
        return value
    if len(value) != 1:
        raise BadArgumentError(f"--hand-split splits one device: give one --{what}, not "
                         f"{len(value)}")
    return value[0]


@dataclass(frozen=True)
class AudioInput:
    """One finger's microphone: input ``channel`` of the ``channels``-input ``device`` (a
    sound card, or a .wav/.flac file standing in for one)."""

    device: str
    channel: int = 0
    channels: int = 1

    @property
    def is_file(self) -> bool:
        return self.device.lower().endswith((".wav", ".flac"))

    @property
    def card(self) -> int | str:
        return int(self.device) if self.device.isdigit() else self.device


def hand_audio_inputs(args: argparse.Namespace, fingers: Sequence[str]
                      ) -> dict[str, AudioInput]:
    """``--hand-audio`` -> finger -> its microphone (without opening anything): one
    multi-input card whose input k is the k-th finger's, or one card per named finger."""
    text = getattr(args, "hand_audio", None)
    if text is None:
        return {}
    if "=" in text:
        per = parse_assignments(text, "--hand-audio")
        unknown = [n for n in per if n not in fingers]
        if unknown:
            raise BadArgumentError(f"--hand-audio: no finger named {unknown[0]!r} "
                             f"(fingers: {', '.join(fingers)})")
        return {n: AudioInput(dev) for n, dev in per.items()}
    return {n: AudioInput(text.strip(), k, len(fingers)) for k, n in enumerate(fingers)}


def hand_audio_from_args(args: argparse.Namespace, fingers: Sequence[str], *,
                         sample_rate: float = 44100.0, dtype: str = "int16"
                         ) -> list[tuple[object, list[str]]]:
    """``--hand-audio`` -> [(source, finger names)]: one source whose channel k is the k-th
    finger's microphone, or one mono source per finger. Sources are not started."""
    inputs = hand_audio_inputs(args, fingers)
    if not inputs:
        return []
    first = next(iter(inputs.values()))
    if first.channels == 1:
        return [(_audio_source(a.device, 1, sample_rate, dtype), [n])
                for n, a in inputs.items()]
    src = _audio_source(first.device, first.channels, sample_rate, dtype)
    if src.channels < len(fingers):
        raise BadArgumentError(f"--hand-audio: {first.device} has {src.channels} channel(s) for "
                         f"{len(fingers)} fingers")
    return [(src, list(fingers))]


def _audio_source(dev: str, channels: int, sample_rate: float, dtype: str):
    from .audio import FileSource, SoundDeviceSource

    if dev.lower().endswith((".wav", ".flac")):
        return FileSource(dev, realtime=True)
    return SoundDeviceSource(int(dev) if dev.isdigit() else dev, sample_rate,
                             channels=channels, dtype=dtype)
