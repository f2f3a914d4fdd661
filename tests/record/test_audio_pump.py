"""The recorder's audio threads: what a source captured before the stop is recorded."""
from __future__ import annotations

import time

import numpy as np

from fingertip.record import Recorder


def test_audio_a_pump_had_not_read_at_close_is_recorded(tmp_path):
    """close() lets the audio pump record what its source captured before the stop; it
    used to refuse those last chunks as dropped whenever the pump was behind (CPU load)."""
    from fingertip.audio import SimulatedSource

    class SlowReads(SimulatedSource):
        def read(self, *args, **kwargs):
            time.sleep(0.05)  # a consumer the scheduler keeps away: data piles up meanwhile
            return super().read(*args, **kwargs)

    src = SlowReads(lambda t: np.sin(t), 44100, realtime=True)
    rec = Recorder(tmp_path / "audio.mcap").start()
    rec.record_audio(src, "index")
    time.sleep(0.3)
    src.stop()
    st = rec.close()
    assert src.stats.frames > 0.25 * 44100
    assert st.dropped == {}
    assert st.audio_frames["index"] == src.stats.frames
