"""Record what the checks need from a :class:`~fingertip.device.Fingertip`: segments of
untared counts with their device times, the device's identity and counters."""
from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..device import Fingertip, FingertipError, Frame
from ..device.outage import host_seconds
from ..protocol import message_to_dict
from .signals import Segment

LINK_COUNTERS = ("rx_overflows", "rx_crc_errors", "rx_framing_errors", "tx_overruns")
log = logging.getLogger(__name__)
BRIDGE_COUNTERS = ("crc_errors", "cobs_errors", "length_errors", "bad_payload", "frames_lost",
                   "overruns")


class DeviceProbe:
    """Wraps an open fingertip for the check; :meth:`restore` puts its settings back.
    ``channels``: check only these of the device's channels (one finger of a device split
    into fingers), seen as channels 0, 1, ... of the segments."""

    def __init__(self, ft: Fingertip, channels: Sequence[int] | None = None,
                 finger: str | None = None) -> None:
        self.ft = ft
        self.info = ft.info
        self.device_channels = None if channels is None else tuple(channels)
        self._cols = list(self.device_channels or range(ft.channels))
        self.channels = len(self._cols)
        self.finger = finger
        self._offsets = tuple(self.info.tare_offsets[:ft.channels])
        self._rate = (self.info.rate_sps, self.info.decimation)
        self.gain = self.info.gain
        self.last_time_s = 0.0
        self._host0: dict[str, int] = {}
        self.host_minus_device_s = 0.0
        """Host clock minus device clock (seconds), from the last frame."""

    def describe(self) -> dict[str, Any]:
        i = self.info
        out = {"port": self.ft.port, "protocol": f"{i.protocol_major}.{i.protocol_minor}",
               "firmware": ".".join(map(str, i.firmware_version)),
               "build_id": f"{i.build_id:08x}", "channels": self.channels, "gain": i.gain}
        if self.device_channels is not None:
            out["device_channels"] = list(self.device_channels)
        return out

    def prepare(self) -> None:
        """Untared counts (bridge balance needs them), 80 SPS, counters zeroed, streaming."""
        self.ft.set_tare_offsets([0] * self.ft.channels)
        self.ft.set_rate(80, 1)
        self.ft.reset_counters()
        self._host0 = {k: int(getattr(self.ft.stats, k)) for k in BRIDGE_COUNTERS}
        self.ft.start()

    def set_rate(self, rate_sps: int) -> None:
        self.ft.set_rate(rate_sps, 1)

    def capture(self, seconds: float, timeout: float = 3.0, since: float | None = None,
                since_device_s: float | None = None) -> Segment:
        """Frames covering ``seconds`` of device time from now, or from the first frame made
        at or after ``since`` (a ``time.monotonic()`` value, e.g. when a person was asked to
        act; a frame's clock-mapped host time says when it was made), or stamped at or after
        ``since_device_s`` (device seconds: when a simulator was asked to act, by its own
        clock). Frames already queued count, so a host that comes late to read loses none of
        the action; frames made before it do not, however late the host read them (a busy
        host's reader can hand over a second of frames at once)."""
        if since is not None and since_device_s is not None:
            raise ValueError("give since or since_device_s, not both")

        def before(f: Frame) -> bool:
            if since_device_s is not None:
                return f.device_time_us * 1e-6 < since_device_s
            return since is not None and host_seconds(f) < since

        queued = self.ft.drain()
        keep = since is not None or since_device_s is not None
        pending = iter([f for f in queued if not before(f)] if keep else ())
        rows: list[Frame] = []
        t_first = None
        deadline = time.monotonic() + seconds * 4 + timeout
        while time.monotonic() < deadline:
            f = next(pending, None)
            if f is None:
                f = self.ft.read(timeout=0.5)
            if f is None:
                if rows and time.monotonic() > deadline - timeout:
                    break
                continue
            if not rows and before(f):
                continue
            t = f.device_time_us * 1e-6
            t_first = t if t_first is None else t_first
            rows.append(f)
            self.last_time_s = t
            self.host_minus_device_s = f.host_time - t
            if t - t_first >= seconds:
                break
        n, c, cols = len(rows), self.channels, self._cols
        counts = np.full((n, c), np.nan)
        tmask = np.zeros(n, np.int64)
        smask = np.zeros(n, np.int64)
        for k, f in enumerate(rows):
            counts[k] = [f.counts[j] for j in cols]
            # the masks' bits renumbered as the segment's columns
            tmask[k] = sum(((f.timeout_mask >> j) & 1) << i for i, j in enumerate(cols))
            smask[k] = sum(((f.saturation_mask >> j) & 1) << i for i, j in enumerate(cols))
        for ch in range(c):
            counts[((tmask >> ch) & 1) == 1, ch] = np.nan
        times = np.array([f.device_time_us * 1e-6 for f in rows])
        return Segment(times, counts, tmask, smask)

    def counters(self) -> dict[str, int] | None:
        """Link counters since :meth:`prepare`; None when the device does not answer."""
        try:
            st = message_to_dict(self.ft.device_stats())
        except FingertipError as e:
            log.warning("no device counters: %s", e)
            return None
        br = self.ft.stats
        out = {f"device.{k}": int(st[k]) for k in LINK_COUNTERS if k in st}
        out.update({f"host.{k}": int(getattr(br, k)) - self._host0.get(k, 0)
                    for k in BRIDGE_COUNTERS})
        return out

    def restore(self) -> None:
        """Stop streaming, put back the rate and the tare offsets (each step tried, a
        failure logged: the report matters more than the clean-up)."""
        for step in (self.ft.stop, lambda: self.ft.set_rate(*self._rate),
                     lambda: self.ft.set_tare_offsets(list(self._offsets))):
            try:
                step()
            except FingertipError as e:
                log.warning("restoring the device's settings: %s", e)
