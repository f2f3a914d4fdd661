"""The touch detector a recipe uses to find an object's face by closing a finger on it."""
from __future__ import annotations

import pytest

from fingertip.tasks.touch import Touch


def test_a_touch_is_the_averaged_force_over_the_rest_reaching_the_threshold():
    # At rest the model reads a small force in some direction: subtracted as a vector.
    t = Touch([(0.05, -0.02), (0.07, -0.02)], threshold_n=0.1, window=4)
    assert t.rest == pytest.approx((0.06, -0.02))
    assert not any(t.feed((0.06, -0.02)) for _ in range(10))      # the rest itself: 0 N
    # Pressing along -x: 0.12 N over the rest, the window fills up frame by frame.
    seen = [t.feed((-0.06, -0.02)) for _ in range(4)]
    assert seen == [False, False, False, True] and t.force_n == pytest.approx(0.12)
    assert t.feed((0.06, -0.02))                                  # once touched, it stays


def test_one_noisy_frame_is_not_a_touch():
    t = Touch([(0.0, 0.0)], threshold_n=0.1, window=4)
    assert not t.feed((0.3, 0.0))                                 # the window is not full
    assert not any(t.feed((0.0, 0.0)) for _ in range(3))          # 0.075 N averaged


def test_bad_settings_are_refused():
    with pytest.raises(ValueError, match="rest frame"):
        Touch([], 0.1)
    with pytest.raises(ValueError, match="threshold"):
        Touch([(0.0, 0.0)], 0.0)
