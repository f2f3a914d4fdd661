"""A thread that reads an audio source and hands its chunks to the recorder until the
recorder stops or the source ends."""
from __future__ import annotations

import logging
import threading
from collections.abc import Callable

from ..audio import AudioSource, Chunk

log = logging.getLogger(__name__)


def pump_thread(source: AudioSource, name: str, write: Callable[[Chunk], object],
                max_seconds: float, stop: threading.Event,
                on_error: Callable[[Exception], None]) -> threading.Thread:
    """A thread (not started; the source is started here if it is not running) that reads
    ``source`` in chunks of at most ``max_seconds`` and calls ``write(chunk)``. Once ``stop``
    is set it still writes what the source had captured, then ends. A failing source is
    logged and given to ``on_error``: it must not end the recording silently."""
    if not source.running and not source.finished:
        source.start()
    max_frames = max(1, int(source.sample_rate * max_seconds))

    def pump() -> None:
        try:
            while not stop.is_set():
                chunk = source.read(max_frames, timeout=0.05)
                if chunk is None:
                    if source.finished:
                        break
                    continue
                write(chunk)
            # What was captured before the stop is still recorded.
            while (chunk := source.read(max_frames, timeout=0)) is not None:
                write(chunk)
        except Exception as e:  # a broken source must not kill the recording silently
            log.error("audio %s: %s", name, e)
            on_error(e)

    return threading.Thread(target=pump, daemon=True, name=f"recorder-audio-{name}")
