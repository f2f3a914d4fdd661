"""One stream session of a hand (``fingertip stream --hand ... | --port P --hand-split 4x4``):
the frames of every finger, tagged with the finger's name (one line or JSON object per
finger frame), then each device's loss counters."""
from __future__ import annotations

import contextlib
from dataclasses import dataclass

from ..device import BridgeStats, FingertipError
from ..device.health import link_text
from ..hand_args import HandSpec
from .session import Say, StreamError, StreamSettings
from .text import frame_json, frame_line


@dataclass(frozen=True)
class HandStreamSummary:
    """The finger frames one session showed, each device's loss counters, and the hand's
    queue overruns."""

    frames: int
    fingers: list[str]
    devices: list[tuple[str, BridgeStats]]
    """(port, its link counters) per device."""
    overruns: int

    def text(self) -> str:
        lines = [f"{port}: {link_text(st)}, COBS errors {st.cobs_errors}"
                 for port, st in self.devices]
        lines.append(f"{self.frames} finger frames ({', '.join(self.fingers)}); hand queue "
                     f"overruns {self.overruns}")
        return "\n".join(lines)


def stream_hand(settings: StreamSettings, spec: HandSpec, *, out: Say) -> HandStreamSummary:
    """Stream the hand ``spec`` describes until the settings' count or duration, or Ctrl-C;
    ``out`` gets one line (or JSON object) per finger frame. A plot is a
    :class:`StreamError` (it shows one fingertip), and so is a split that names channels
    the device does not have. Everything opened is closed whatever happens."""
    if settings.plotting:
        raise StreamError("--plot shows one fingertip: stream a hand without it")
    hand = spec.build()
    try:
        try:
            hand.open()  # refuses a split that names channels the device does not have
        except ValueError as e:
            raise StreamError(str(e)) from e
        for dev in hand.devices:
            settings.apply(dev)
        if settings.tare:
            hand.tare(samples=settings.tare)
        hand.start()
        more = settings.until()
        n = 0
        try:
            while more(n):
                ff = hand.read(timeout=1.0)
                if ff is None:
                    continue
                n += 1
                f = ff.frame
                if settings.json:
                    out(frame_json(f, finger=ff.finger))
                else:
                    out(f"{ff.finger:<8} " + frame_line(f))
        except KeyboardInterrupt:
            pass
        finally:
            with contextlib.suppress(FingertipError):
                hand.stop()
        devices = [(dev.port, dev.stats) for dev in hand.devices]
        return HandStreamSummary(n, hand.fingers, devices, hand.overruns)
    finally:
        hand.close()
