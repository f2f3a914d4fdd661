"""What a :class:`~fingertip.device.Fingertip` keeps about its device: the counters of what
the host saw and lost, and the set-up it wants the device to have."""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(slots=True)
class BridgeStats:
    """What the host saw (the device's own counters: :meth:`Fingertip.device_stats`)."""

    frames_ok: int = 0
    bytes_in: int = 0
    crc_errors: int = 0
    cobs_errors: int = 0
    length_errors: int = 0
    """Frames too short or too long (the device's ``rx_framing_errors`` is another count: COBS
    errors and short frames among the commands it received)."""
    unknown_type: int = 0
    bad_payload: int = 0
    seq_gaps: int = 0
    frames_lost: int = 0
    """Frames missing: by sequence number inside a connection, plus ``outage_frames``."""
    outage_frames: int = 0
    """Sample frames missing across outages (link lost and back, device restarted):
    :mod:`fingertip.device.outage`."""
    overruns: int = 0
    """Frames dropped because user code did not read the queue fast enough (never counted
    with ``queue_size=0``: there is no queue, callbacks get every frame)."""
    reconnects: int = 0
    device_resets: int = 0
    callback_errors: int = 0
    command_retries: int = 0
    log_lines: int = 0
    foreign_devices: int = 0
    """Reconnects refused because another kind of device answered on the port (another
    firmware, build or channel count): its frames are never handed out."""


@dataclass
class Settings:
    """What the host wants the device to be; re-applied after a reconnect or reset."""

    rate_sps: int = 80
    decimation: int = 1
    gain: int = 128
    offsets: tuple[int, ...] = ()
    streaming: bool = False
