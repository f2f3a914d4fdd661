"""The paired sound card, recorded during the tap step (real hardware)."""
from __future__ import annotations

import numpy as np

from ..audio import SoundDeviceSource


class SoundCardAudio:
    """Records the card between :meth:`start` and :meth:`stop`. Times are converted to the
    device clock with the probe's host-device offset (the bridge's clock mapping).
    ``channel`` of a ``channels``-input card (a hand's 4-input interface: one per finger)."""

    def __init__(self, device: int | str, probe, samplerate: float = 44100, *,
                 channel: int = 0, channels: int = 1) -> None:
        if not 0 <= channel < channels:
            raise ValueError(f"input {channel} of a {channels}-input card")
        self.device = device
        self.channel = channel
        self.channels = channels
        self.probe = probe
        self.sample_rate = float(samplerate)
        self.name = str(device) if channels == 1 else f"{device} input {channel + 1}"
        self._src: SoundDeviceSource | None = None

    def start(self, device_time_s: float) -> None:
        self._src = SoundDeviceSource(self.device, self.sample_rate, channels=self.channels,
                                      dtype="float32").start()
        self.sample_rate = float(self._src.sample_rate)

    def stop(self, device_time_s: float) -> tuple[np.ndarray, float]:
        src, self._src = self._src, None
        assert src is not None
        # Stop first, then drain what was captured: a live card keeps delivering, so reading
        # until a read comes back empty could go on for ever.
        src.stop()
        chunks = []
        while (c := src.read(timeout=0)) is not None and c.frames:
            chunks.append(c)
        if not chunks:
            return np.zeros(0, np.float32), device_time_s
        x = np.concatenate([c.samples.reshape(len(c.samples), -1)[:, self.channel]
                            for c in chunks])
        return x, chunks[0].host_time - self.probe.host_minus_device_s
