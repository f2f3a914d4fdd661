"""Guides: who performs the check's hands-on steps (press a face, tap the nail).

:class:`PromptGuide` asks a person on the terminal; :class:`NoPromptGuide` skips the steps
(``--no-prompt``) and the report lists what was skipped. The virtual fingertip has its own
guide (:class:`fingertip.sim.device.bringup.SimGuide`) that lets the simulator press.
"""
from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Protocol


class Guide(Protocol):
    """A simulated guide may also have ``acted_at_s``: the device time (seconds, the clock
    of the frames' stamps) at which its last step was asked. The check then records the
    step from the first frame stamped at or after it. Without it, the step is recorded from
    the first frame made (by its clock-mapped host time) after the step was asked or, for a
    person, after the prompt returned."""

    interactive: bool
    simulated: bool

    def press(self, face: int, label: str) -> bool:
        """Have the ``label`` face pressed; False when the step is skipped."""

    def tap(self, count: int) -> bool:
        """Have the nail tapped ``count`` times; False when skipped."""


class NoPromptGuide:
    interactive = False
    simulated = False

    def press(self, face: int, label: str) -> bool:
        return False

    def tap(self, count: int) -> bool:
        return False


class PromptGuide:
    """Asks on the terminal: the person presses Enter, then acts while the check records."""

    interactive = True
    simulated = False

    def __init__(self, ask: Callable[[str], str] = input, say: Callable[[str], None] | None = None
                 ) -> None:
        self._ask = ask
        self._say = say or (lambda s: print(s, file=sys.stderr, flush=True))

    def _step(self, text: str) -> bool:
        try:
            answer = self._ask(f"{text}\n  Enter when ready, s + Enter to skip: ")
        except EOFError:
            return False
        if answer.strip().lower().startswith("s"):
            return False
        self._say("  GO")
        return True

    def press(self, face: int, label: str) -> bool:
        return self._step(f"Press the {label} face towards the centre with a finger (about "
                          "2 N, as for a firm button), hold 1 s, release.")

    def tap(self, count: int) -> bool:
        return self._step(f"Tap the nail {count} times with a fingertip or a pen, about "
                          "twice a second.")
