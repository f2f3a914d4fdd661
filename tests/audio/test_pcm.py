"""Float samples to and from a card's integer formats: one rounding and clipping rule."""
from __future__ import annotations

import numpy as np
import pytest

from fingertip.audio.pcm import to_float, to_pcm


def test_int16_rounds_to_the_nearest_step_and_clips_like_a_card():
    x = np.array([0.0, 0.5, -0.5, 1.0, -1.0, 2.0, -2.0, 1.4 / 32768, 1.6 / 32768])
    assert to_pcm(x, "int16").tolist() == [0, 16384, -16384, 32767, -32768, 32767, -32768, 1, 2]
    assert to_pcm(x, "int16").dtype == np.int16


def test_reading_back_inverts_writing_on_the_16_bit_grid():
    k = np.arange(-32768, 32768, 7, dtype=np.int16)
    assert np.array_equal(to_pcm(to_float(k), "int16"), k)
    assert to_float(np.array([-32768], np.int16))[0] == -1.0


def test_int32_and_float_inputs():
    assert to_pcm(np.array([0.25, 3.0]), "int32").tolist() == [536870912, 2147483647]
    assert to_float(np.array([1 << 30], np.int32))[0] == 0.5
    f = np.array([0.25], np.float32)
    assert to_float(f).dtype == np.float64 and to_float(f)[0] == 0.25


def test_buffers_are_filled_in_place_and_one_channel_broadcasts():
    out = np.zeros((4, 2), np.int16)
    work = np.zeros((4, 2))
    got = to_pcm(np.full((4, 1), 0.5), np.int16, out=out, work=work)
    assert got is out and (out == 16384).all()


def test_a_float_target_is_refused():
    with pytest.raises(ValueError, match="int16 or int32, not float32"):
        to_pcm(np.zeros(3), "float32")
