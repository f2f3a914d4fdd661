"""The known-weights procedure: masses, checks, and a virtual unit end to end."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from fingertip.models.force.weights import (
    G,
    PromptWeightsGuide,
    WeightsError,
    WeightsSession,
    WeightStep,
    parse_mass,
)


@pytest.mark.parametrize("text,grams", [("100", 100.0), (" 50 g", 50.0), ("0.2kg", 200.0),
                                        ("", None)])
def test_parse_mass(text, grams):
    assert parse_mass(text) == grams


@pytest.mark.parametrize("text", ["-5", "abc", "0", "nan"])
def test_parse_mass_bad(text):
    with pytest.raises(ValueError):
        parse_mass(text)


def steps(dirs, masses):
    return [WeightStep(d, m, np.zeros((10, 4))) for d in dirs for m in masses]


def test_session_checks():
    with pytest.raises(WeightsError, match="at least 3"):
        WeightsSession(steps(["+X", "+Y"], [50, 100])).check()
    with pytest.raises(WeightsError, match="one axis only"):
        WeightsSession(steps(["+X", "-X"], [50, 100, 200])).check()
    WeightsSession(steps(["+X", "-Y"], [50, 100, 200])).check()
    s = WeightStep("-Y", 100.0, np.zeros((1, 4)))
    assert s.force == pytest.approx([0.0, -0.1 * G])


def test_prompt_guide_retries_bad_input():
    answers = iter(["heavy", "120 g"])
    g = PromptWeightsGuide(ask=lambda _q: next(answers))
    assert g.place("+X", 0) == 120.0


def test_virtual_weights_end_to_end(tmp_path):
    r = subprocess.run([sys.executable, "-m", "fingertip.cli", "calibrate", "weights",
                        "--virtual", "--speed", "4", "--masses", "50,150,300", "-o", "cal",
                        "-q"], cwd=tmp_path, capture_output=True, text=True, timeout=180)
    assert r.returncode == 0, r.stderr
    from fingertip.models.force.runtime import ForceModel

    m = ForceModel(tmp_path / "cal" / "force.onnx")
    assert m.metadata["reference"] == "known weights" and m.rmse_n < 0.3
