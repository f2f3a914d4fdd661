"""Manipulation recipes built on the fingertip layers (device, models, events).

Recipes talk to the robot only through :class:`RobotHand` and :class:`RobotArm`
(:mod:`.interfaces`); :mod:`.sim_world` implements both in a simulated world.
"""
from .interfaces import FrameSet, RobotArm, RobotHand
from .pinch import PinchConfig, PinchOutcome, PinchResult, demonstrate_threshold, pinch

__all__ = ["FrameSet", "PinchConfig", "PinchOutcome", "PinchResult", "RobotArm", "RobotHand",
           "demonstrate_threshold", "pinch"]
