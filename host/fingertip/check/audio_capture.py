"""The paired sound card, recorded during the tap step (real hardware)."""
from __future__ import annotations

import numpy as np

from ..audio import SoundDeviceSource


class SoundCardAudio:
    """Records the card between :meth:`start` and :meth:`stop`. Times are converted to the
    device clock with the probe's host-device offset (the bridge's clock mapping)."""

    def __init__(self, device: int | str, probe, samplerate: float = 44100) -> None:
        self.device = device
        self.probe = probe
        self.sample_rate = float(samplerate)
        self.name = str(device)
        self._src: SoundDeviceSource | None = None

    def start(self, device_time_s: float) -> None:
        self._src = SoundDeviceSource(self.device, self.sample_rate, channels=1,
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
        x = np.concatenate([c.samples.reshape(len(c.samples), -1)[:, 0] for c in chunks])
        return x, chunks[0].host_time - self.probe.host_minus_device_s
