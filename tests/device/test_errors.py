"""The argument checks name the allowed range; a NACK names its error code."""
from __future__ import annotations

import pytest

from fingertip.device import CommandFailed, FingertipError
from fingertip.device.errors import check_int, check_tare_samples
from fingertip.protocol import ErrorCode


def test_check_int_takes_integers_in_range_only():
    assert check_int("x", 3, 0, 5) == 3
    with pytest.raises(ValueError, match=r"x must be in 0\.\.5, not 6"):
        check_int("x", 6, 0, 5)
    for bad in (True, 2.0, "2", None):
        with pytest.raises(TypeError, match=r"x must be an integer in 0\.\.5"):
            check_int("x", bad, 0, 5)


def test_tare_samples_are_the_firmwares_limit():
    assert check_tare_samples(0) == 0 and check_tare_samples(256) == 256
    with pytest.raises(ValueError, match=r"tare samples must be in 0\.\.256"):
        check_tare_samples(257)


def test_a_nack_names_its_code_even_an_unknown_one():
    e = CommandFailed("Tare", ErrorCode.BAD_ARGUMENT)
    assert isinstance(e, FingertipError) and e.code == ErrorCode.BAD_ARGUMENT
    assert str(e) == "Tare refused by the device: BAD_ARGUMENT"
    assert str(CommandFailed("Start", 250)) == "Start refused by the device: error 250"
