"""Manipulation recipes built on the fingertip layers (device, models, events).

Recipes talk to the robot only through :class:`RobotHand` and :class:`RobotArm`
(:mod:`.interfaces`) and the sensor streams, so they run unchanged on a real robot; nothing
here imports the simulator (:mod:`fingertip.sim.world` implements the interfaces in a
simulated world and :mod:`fingertip.sim.experiment` runs the paper's protocols on it). The
cup and shake recipes (:mod:`.cups`, :mod:`.shake_pick`) are imported from their modules
(they pull in the events and classifier code).
"""
from .grip import Grip
from .interfaces import AudioBlock, FrameSet, RobotArm, RobotHand
from .pinch import PinchConfig, PinchOutcome, PinchResult, demonstrate_threshold, pinch

__all__ = ["AudioBlock", "FrameSet", "Grip", "PinchConfig", "PinchOutcome", "PinchResult",
           "RobotArm", "RobotHand", "demonstrate_threshold", "pinch"]
