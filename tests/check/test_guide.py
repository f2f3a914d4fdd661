"""The terminal guide: Enter performs a step, s skips it, end of input skips the rest."""
from __future__ import annotations

from fingertip.check.guide import NoPromptGuide, PromptGuide


def test_prompt_guide_answers():
    asked, said = [], []
    answers = iter(["", "s", "S kip"])
    g = PromptGuide(ask=lambda q: (asked.append(q), next(answers))[1], say=said.append)
    assert g.press(0, "+X") is True and said == ["  GO"]
    assert g.press(1, "+Y") is False
    assert g.tap(3) is False
    assert "Press the +X face" in asked[0] and "Tap the nail 3 times" in asked[2]


def test_prompt_guide_end_of_input():
    def eof(_q):
        raise EOFError

    assert PromptGuide(ask=eof).press(2, "-X") is False
    assert NoPromptGuide().press(0, "+X") is False and NoPromptGuide().tap(3) is False


def test_finger_guide_names_the_finger_in_each_step():
    from fingertip.check.guide import PromptGuide
    from fingertip.check.hand import FingerGuide

    asked: list[str] = []
    g = FingerGuide(PromptGuide(ask=lambda q: asked.append(q) or "", say=lambda s: None), "ring")
    assert g.interactive and not g.simulated
    assert g.press(0, "+x")
    assert "Press the ring fingertip's +x face" in asked[0]
    assert g.tap(3) and "Tap the nail 3 times" in asked[1]
