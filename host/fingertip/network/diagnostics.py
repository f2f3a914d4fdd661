"""The fingertips' health on ROS 2's ``/diagnostics``: ``diagnostic_msgs/msg/DiagnosticArray``
once a second, one ``DiagnosticStatus`` per fingertip, in the layout ROS's
``diagnostic_updater`` publishes (ros/diagnostics, ``diagnostic_updater.hpp``, ROS 2):

- topic ``/diagnostics``, reliable, volatile, keep last 1, every 1.0 s (its default period);
- ``header.stamp`` the time of the update, ``header.frame_id`` empty;
- each status named ``"<node name>: <task name>"`` (here ``fingertip: index``), its
  ``hardware_id`` the device's USB serial number, else its port, else ``none`` (what the
  updater asks of devices without one), its values ``KeyValue`` strings.

The levels follow the rules in docs/reliability.md ("Health on /diagnostics"):
:func:`assess` is pure and takes what :class:`Health` gathered (the bridge's counters, the
frames' timeout and saturation bits, the audio's overruns).
"""
from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from ..record.schemas import CdrWriter

DIAGNOSTIC_ARRAY = "diagnostic_msgs/msg/DiagnosticArray"
DIAGNOSTIC_STATUS = "diagnostic_msgs/msg/DiagnosticStatus"
KEY_VALUE = "diagnostic_msgs/msg/KeyValue"
DEFINITIONS = {
    # ros2/common_interfaces diagnostic_msgs/msg (comments left out: they do not change the
    # type hash, which the tests compare with the one rosbags computes for its copy).
    DIAGNOSTIC_ARRAY: "std_msgs/Header header\ndiagnostic_msgs/DiagnosticStatus[] status",
    DIAGNOSTIC_STATUS: "byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\nbyte level\n"
                       "string name\nstring message\nstring hardware_id\n"
                       "diagnostic_msgs/KeyValue[] values",
    KEY_VALUE: "string key\nstring value",
}
TOPIC = "/diagnostics"
PERIOD_S = 1.0
"""diagnostic_updater's default period."""
NODE = "fingertip"
"""The node name our publishers announce (DDS ``ros_discovery_info``, Zenoh tokens)."""

OK, WARN, ERROR, STALE = 0, 1, 2, 3
LEVEL_NAMES = {OK: "OK", WARN: "WARN", ERROR: "ERROR", STALE: "STALE"}

STALL_S = 2.0
"""A streaming device that sent no frame for this long (or three frame periods, if longer)
is an ERROR: connected but silent (a hung firmware, a stopped stream)."""
HOLD_S = 10.0
"""A loss, error or reconnect keeps its fingertip at WARN this long (a status read once a
second by people and monitors: a one-second flash would go unseen)."""

WARN_COUNTERS = {
    "frames_lost": "frames lost",
    "crc_errors": "CRC errors",
    "cobs_errors": "framing errors",
    "length_errors": "framing errors",
    "reconnects": "reconnected",
    "device_resets": "device restarted",
    "overruns": "frames overrun in the queue",
    "audio.overruns_frames": "audio frames overrun",
}
"""Counters whose growth within :data:`HOLD_S` is a WARN, and how the message says it."""


@dataclass(frozen=True, slots=True)
class Status:
    """One ``diagnostic_msgs/msg/DiagnosticStatus``."""

    level: int
    name: str
    message: str
    hardware_id: str
    values: tuple[tuple[str, str], ...] = ()


@dataclass
class Window:
    """What one fingertip did since the last update, and its counters now."""

    connected: bool = True
    gone_s: float | None = None
    frames: int = 0
    """Frames in the last period."""
    streaming: bool = True
    """Frames are expected (started, not a replay that ended)."""
    silent_s: float = 0.0
    """Seconds since the last frame (since the start, before the first)."""
    frame_period_s: float = 0.0125
    """The device's nominal seconds between frames (rate and decimation)."""
    channels: int = 0
    timeout_any: int = 0
    """Channels that timed out in some frame of the period (absent or failing chips)."""
    timeout_all: int = 0
    """Channels that timed out in every frame of the period (absent chips)."""
    saturated_any: int = 0
    counters: dict[str, int] = field(default_factory=dict)
    grown: dict[str, int] = field(default_factory=dict)
    """How much each of :data:`WARN_COUNTERS` grew within :data:`HOLD_S`."""


def channel_list(mask: int) -> str:
    """``0b0101`` -> ``"0,2"``."""
    return ",".join(str(c) for c in range(16) if mask >> c & 1)


def assess(w: Window) -> tuple[int, str]:
    """``(level, message)`` of one fingertip, by the rules of docs/reliability.md."""
    if not w.connected:
        gone = f" for {w.gone_s:.0f} s" if w.gone_s is not None else ""
        return ERROR, f"device away{gone}, reconnecting"
    all_channels = (1 << w.channels) - 1
    if w.streaming and w.frames and w.channels and w.timeout_all & all_channels == all_channels:
        return ERROR, "no chip answers (every channel timed out)"
    if w.streaming and w.silent_s > max(STALL_S, 3 * w.frame_period_s):
        return ERROR, f"no frames for {w.silent_s:.0f} s"
    grown: dict[str, int] = {}
    for key, text in WARN_COUNTERS.items():
        if w.grown.get(key, 0) > 0:
            grown[text] = grown.get(text, 0) + w.grown[key]
    said = [f"{text} ({n} in {HOLD_S:g} s)" for text, n in grown.items()]
    if w.timeout_any:
        said.append(f"chips absent or failing on channel {channel_list(w.timeout_any)}")
    if w.saturated_any:
        said.append(f"saturated on channel {channel_list(w.saturated_any)}")
    if said:
        return WARN, "; ".join(said)
    return OK, "streaming" if w.streaming else "idle"


def status_of(name: str, hardware_id: str, w: Window, rate_hz: float | None) -> Status:
    """The ``DiagnosticStatus`` of fingertip ``name`` (named as diagnostic_updater names it)."""
    level, message = assess(w)
    values = [("status", "connected" if w.connected else "reconnecting")]
    if w.gone_s is not None:
        values.append(("gone_s", f"{w.gone_s:.1f}"))
    if rate_hz is not None:
        values.append(("frame_rate_hz", f"{rate_hz:.1f}"))
    values += [("absent_channels", channel_list(w.timeout_all)),
               ("timeout_channels", channel_list(w.timeout_any)),
               ("saturated_channels", channel_list(w.saturated_any))]
    values += [(k, str(v)) for k, v in w.counters.items()]
    return Status(level, f"{NODE}: {name}", message, hardware_id or "none", tuple(values))


def encode_diagnostic_array(stamp_ns: int, statuses: Sequence[Status]) -> bytes:
    """``diagnostic_msgs/msg/DiagnosticArray`` in little-endian CDR (the recorder's codec)."""
    w = CdrWriter()
    w.header(stamp_ns, "")
    w.u32(len(statuses))
    for s in statuses:
        w.u8(s.level)
        w.string(s.name)
        w.string(s.message)
        w.string(s.hardware_id)
        w.u32(len(s.values))
        for k, v in s.values:
            w.string(k)
            w.string(v)
    return bytes(w.buf)


BRIDGE_KEYS = ("frames_ok", "frames_lost", "outage_frames", "crc_errors", "cobs_errors",
               "length_errors", "reconnects", "device_resets", "overruns")
"""The bridge's counters (docs/protocol.md) a status carries, under their own names."""


class Health:
    """Gathers one fingertip's health between updates: attach :meth:`on_frame` as a frame
    callback and call :meth:`update` once a period."""

    def __init__(self, source: Any, name: str) -> None:
        self.source = source
        self.name = name
        dev = getattr(source, "device", source)  # a hand's finger: its device's link
        self._dev = dev
        self.hardware_id = (getattr(source, "serial_number", None)
                            or getattr(source, "port", "") or "none")
        self._lock = threading.Lock()
        self._frames = 0
        self._t_any = self._sat_any = 0
        self._t_all = -1
        self._history: deque[tuple[float, dict[str, int]]] = deque()
        self._last_update: float | None = None
        self._last_frame = time.monotonic()

    def on_frame(self, frame: Any) -> None:
        t, s = frame.timeout_mask, frame.saturation_mask
        with self._lock:
            self._last_frame = time.monotonic()
            self._frames += 1
            self._t_any |= t
            self._t_all &= t
            self._sat_any |= s

    def update(self, now: float, streaming: bool = True, audio_overruns_frames: int = 0
               ) -> Status:
        """The status over the period that ends ``now`` (``audio_overruns_frames``: the
        microphone's frames lost so far); starts the next period."""
        with self._lock:
            frames, t_any, t_all, sat = self._frames, self._t_any, self._t_all, self._sat_any
            self._frames, self._t_any, self._t_all, self._sat_any = 0, 0, -1, 0
            silent = max(0.0, now - self._last_frame)
        stats = getattr(self.source, "stats", None)
        counters = {k: int(getattr(stats, k)) for k in BRIDGE_KEYS if hasattr(stats, k)}
        counters["audio.overruns_frames"] = audio_overruns_frames
        self._history.append((now, counters))
        while self._history and now - self._history[0][0] > HOLD_S:
            self._history.popleft()
        oldest = self._history[0][1]
        grown = {k: counters[k] - oldest.get(k, 0) for k in WARN_COUNTERS if k in counters}
        try:
            channels = int(self.source.channels)
        except Exception:  # not open (yet): no channel is known
            channels = 0
        connected = getattr(self._dev, "status", "connected") == "connected"
        settings = getattr(self._dev, "settings", None)
        try:
            period_s = settings.decimation / settings.rate_sps  # type: ignore[union-attr]
        except (AttributeError, TypeError, ZeroDivisionError):
            period_s = 0.0
        w = Window(connected=connected, gone_s=getattr(self._dev, "gone_s", None),
                   frames=frames, streaming=streaming, silent_s=silent,
                   frame_period_s=period_s, channels=channels,
                   timeout_any=t_any, timeout_all=t_all if frames else 0,
                   saturated_any=sat, counters=counters, grown=grown)
        period = None if self._last_update is None else now - self._last_update
        self._last_update = now
        rate = frames / period if period else None
        return status_of(self.name, self.hardware_id, w, rate)
