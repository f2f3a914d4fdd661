"""Recording what is published on the network: ``fingertip record --from dds|zenoh|lsl``.

DDS and Zenoh deliver the publisher's CDR bytes: they are written to the MCAP file as
received (``ros2 bag record`` does the same), logged at their header stamp, so the file
holds what a local recording of the same run holds. LSL carries values, not CDR: its
samples are re-encoded into the same messages (:mod:`.lsl`).
"""
from __future__ import annotations

import logging
import struct
import threading
import time

from ..record import schemas as S
from ..record.recorder import Recorder
from ..record.timebase import NS

log = logging.getLogger(__name__)

_STAMP = struct.Struct("<iI")


def stamp_ns(kind: str, data: bytes) -> int | None:
    """The header stamp of a little-endian CDR message of a stamped kind, else None."""
    if kind == "info" or len(data) < 12 or bytes(data[:2]) != b"\x00\x01":
        return None
    sec, nsec = _STAMP.unpack_from(data, 4)
    return sec * NS + nsec


class NetworkRecorder:
    """Feed ``recorder`` with the messages of fingertips ``names`` from ``source``."""

    def __init__(self, recorder: Recorder, source: str, names: list[str], *,
                 connect: list[str] | None = None, listen: list[str] | None = None) -> None:
        self.recorder = recorder
        self.names = names
        self.bad = 0
        # Every key made now: the reader threads only update values, so another thread can
        # copy the dict meanwhile.
        self.heard: dict[str, float | None] = dict.fromkeys(names)
        """Fingertip -> ``time.monotonic()`` of its last message (None before the first)."""
        self._audio_declared: set[str] = set()
        self._lock = threading.Lock()
        if source == "dds":
            from .dds import DdsNode, subscribe

            self._node = DdsNode()
            subscribe(self._node, names, self.on_message)
        elif source == "zenoh":
            from .zenoh import ZenohNode

            self._node = ZenohNode(connect, listen)
            self._node.subscribe(names, self.on_message)
        elif source == "lsl":
            from .lsl import LslReceiver

            self._node = LslReceiver(names, self.on_message)
        else:
            raise ValueError(f"unknown source {source!r}: dds, zenoh or lsl")

    def on_message(self, name: str, kind: str, data: bytes) -> None:
        """One message ``data`` (CDR) of ``/fingertip/<name>/<kind>``."""
        self.heard[name] = time.monotonic()
        try:
            msg = S.DECODERS[S.TOPIC_KINDS[kind]](data)  # refuse what does not decode
        except Exception as e:
            with self._lock:
                self.bad += 1
            log.warning("%s %s: undecodable message of %d bytes (%s)", name, kind, len(data), e)
            return
        if kind == "audio" and name not in self._audio_declared:
            self._audio_declared.add(name)
            self.recorder.add_audio(name, sample_rate=msg.sample_rate, channels=msg.channels,
                                    dtype=S.AUDIO_DTYPES[msg.encoding], source="network")
        ns = stamp_ns(kind, data)
        if ns is None:
            ns = self.recorder.timebase.to_ns(time.monotonic())
        self.recorder.write_encoded(name, kind, ns, data)

    def close(self) -> None:
        self._node.close()
