"""``FingerView``: one finger of an open :class:`~fingertip.device.Hand` as a frame source of
its own, for code written for a single fingertip (a publisher, a recorder's ``attach``).

Its frames hold only the finger's channels (the Hand selects them); commands that act on the
whole device (start, stop) are sent once per device however many fingers share it, and a
tare tares only the finger's channels.
"""
from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass

from .errors import check_tare_samples
from .fingertip import Fingertip
from .frames import Frame
from .hand import Hand
from .state import BridgeStats


@dataclass(frozen=True)
class FingerSettings:
    finger: str
    device_channels: list[int] | None


class FingerView:
    """Finger ``finger`` of ``hand`` (opened by the caller), under the finger's name."""

    def __init__(self, hand: Hand, finger: str, streaming: dict[int, int]) -> None:
        self.hand = hand
        self.name = finger
        self.device: Fingertip = hand.device(finger)
        self.device_channels = hand.channels_of(finger)
        # shared between the views of one hand: device id -> fingers that started it, so
        # that the device gets one Start and stops with the last finger
        self._streaming = streaming
        self._lock = threading.Lock()
        self._callbacks: dict[Callable[[Frame], None], Callable[[str, Frame], None]] = {}

    @property
    def port(self) -> str:
        return self.device.port

    @property
    def serial_number(self) -> str | None:
        return getattr(self.device, "serial_number", None)

    @property
    def info(self):
        return self.device.info

    @property
    def channels(self) -> int:
        chans = self.device_channels
        return self.device.channels if chans is None else len(chans)

    @property
    def stats(self) -> BridgeStats:
        return self.device.stats

    @property
    def settings(self) -> FingerSettings:
        """What a subscriber of ``info`` needs beyond the device's INFO: which of the
        device's channels this finger is."""
        return FingerSettings(self.name, None if self.device_channels is None
                              else list(self.device_channels))

    def add_callback(self, fn: Callable[[Frame], None]) -> None:
        def on_finger(finger: str, frame: Frame, _fn=fn) -> None:
            if finger == self.name:
                _fn(frame)
        with self._lock:
            self._callbacks[fn] = on_finger
        self.hand.add_callback(on_finger)

    def remove_callback(self, fn: Callable[[Frame], None]) -> None:
        with self._lock:
            on_finger = self._callbacks.pop(fn, None)
        if on_finger is None:
            raise ValueError("callback not registered")
        self.hand.remove_callback(on_finger)

    def start(self) -> None:
        key = id(self.device)
        with _START_LOCK:
            if self._streaming.get(key, 0) == 0:
                self.device.start()
            self._streaming[key] = self._streaming.get(key, 0) + 1

    def stop(self) -> None:
        key = id(self.device)
        with _START_LOCK:
            n = self._streaming.get(key, 0)
            if n <= 0:
                return
            self._streaming[key] = n - 1
            if n == 1:
                self.device.stop()

    def tare(self, samples: int = 16) -> tuple[int, ...]:
        """Tare this finger's channels only; returns their offsets."""
        samples = check_tare_samples(samples)
        chans = self.device_channels
        offsets = self.device.tare(None if chans is None else list(chans), samples=samples)
        return tuple(offsets) if chans is None else tuple(offsets[c] for c in chans)


_START_LOCK = threading.Lock()


def finger_views(hand: Hand) -> list[FingerView]:
    """One view per finger of ``hand``, in the hand's order."""
    streaming: dict[int, int] = {}
    return [FingerView(hand, f, streaming) for f in hand.fingers]
