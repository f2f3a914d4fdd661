"""Taking a fingertip back after a reconnect or a device reset: is it the same device, and
its set-up (rate, gain, tare offsets, streaming) re-applied.

After a reconnect, the frame path holds frames back (``_held``) until :class:`SetupRestore`
has seen the device's INFO: the same firmware, build and channels give the verdict "ok"
and the held frames go out; another device gives "foreign", its frames are dropped and the
port is let go until the right device returns. The verdict is applied on the reader thread.
"""
from __future__ import annotations

import logging
import threading
from collections import deque

from ..protocol import MAX_CHANNELS, Info, SetGain, SetRate, SetTareOffsets, Start
from ..transport import TransportError
from .errors import FingertipError
from .frames import Frame
from .state import BridgeStats, Settings

log = logging.getLogger(__name__)


def identity(info: Info) -> tuple:
    """What must not change across a reconnect: protocol, firmware, build, channels."""
    return (info.protocol_major, tuple(info.firmware_version), info.build_id, info.channels)


def describe(ident: tuple) -> str:
    major, fw, build, channels = ident
    return f"{'.'.join(map(str, fw))} build {build:08x}, {channels} channels, protocol v{major}"


class SetupRestore:
    """The restorer thread of a :class:`~fingertip.device.Fingertip` (a mixin: the
    attributes below are the device's, set in its ``__init__``; ``_handshake`` and
    ``_command`` are its commands', ``_lost`` and ``_deliver`` its link's and frame path's)."""

    name: str
    port: str
    open_timeout: float
    settings: Settings
    _counters: BridgeStats
    _closing: threading.Event
    _restore_needed: threading.Event
    _identity: tuple | None
    _verifying: bool
    _held: deque[Frame]
    _verdict: tuple[int, str] | None
    _connection: int

    def _restore_loop(self) -> None:
        while True:
            self._restore_needed.wait()
            if self._closing.is_set():
                return
            self._restore_needed.clear()
            try:
                self._restore()
            except (FingertipError, TransportError) as e:
                if self._closing.is_set():
                    return
                log.warning("%s: restoring the set-up failed (%s); will retry", self.name, e)
                self._closing.wait(0.1)
                self._restore_needed.set()

    def _apply_verdict(self) -> None:
        """On the reader thread: release the held frames, or drop the foreign device."""
        (connection, verdict), self._verdict = self._verdict, None
        if connection != self._connection:
            return  # about a connection that is gone
        held = list(self._held)
        self._held.clear()
        if verdict == "foreign":
            self._lost()
            return
        self._verifying = False
        for f in held:
            self._deliver(f)

    def _restore(self) -> None:
        want = self.settings
        connection = self._connection
        info = self._handshake(self.open_timeout)
        if self._identity is not None and identity(info) != self._identity:
            self._counters.foreign_devices += 1
            self._verdict = (connection, "foreign")
            raise FingertipError(
                f"{self.name}: the device now on {self.port} is not the one opened (firmware "
                f"{describe(identity(info))}, expected {describe(self._identity)}); "
                f"its frames are dropped and the port is left until the right one returns")
        if self._verifying:
            self._verdict = (connection, "ok")
        if (info.rate_sps, info.decimation) != (want.rate_sps, want.decimation):
            self._command(SetRate(0, want.rate_sps, want.decimation))
        if info.gain != want.gain:
            self._command(SetGain(0, want.gain))
        if want.offsets and any(want.offsets) and info.tare_offsets != want.offsets:
            padded = tuple(want.offsets) + (0,) * (MAX_CHANNELS - len(want.offsets))
            self._command(SetTareOffsets(0, (1 << len(want.offsets)) - 1, padded))
        if want.streaming and not info.streaming:
            self._command(Start())
        log.info("%s: set-up restored", self.name)
