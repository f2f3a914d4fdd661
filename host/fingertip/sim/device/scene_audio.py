"""A simulated contact microphone as a live audio source: the piezo signal of one sliding
material or one shaken box, played through :class:`~fingertip.audio.SimulatedSource`, so
that a classifier can be tried live with no sound card (``fingertip classify --simulate``)."""
from __future__ import annotations

import numpy as np

from ...audio import SimulatedSource
from ...errors import BadArgumentError
from ..physics import BOX_CONTENTS, BoxShake, Slide, material, simulate


class UnknownScene(BadArgumentError, LookupError):
    """``--simulate NAME`` names no material or box content (exit status 2; a LookupError,
    as before, and a ValueError)."""


def scene_audio_source(name: str, kind: str, duration: float | None = None,
                       realtime: bool = True, seed: int = 0) -> SimulatedSource:
    """The microphone of a slide over material ``name`` or, for ``kind == "shake"`` (or a
    name that is a box content), of a shaken box holding ``name``; ``duration`` defaults to
    3.0 s for a slide and 5.6 s for a shake. An unknown name raises :class:`UnknownScene`
    (a LookupError; one line naming the choices)."""
    if kind == "shake" or name in BOX_CONTENTS:
        if name not in BOX_CONTENTS:
            raise UnknownScene(f"--simulate for shake takes one of {', '.join(BOX_CONTENTS)}")
        scene = BoxShake(name, duration=duration or 5.6, seed=seed)
    else:
        try:
            m = material(name)
        except ValueError as e:
            raise UnknownScene(str(e)) from None
        scene = Slide(m.name, duration=duration or 3.0, seed=seed)
    audio = simulate(scene, seed=seed).audio
    if audio is None:  # simulate() always renders a scene's audio; say so if it ever stops
        raise RuntimeError(f"the simulation of {scene.name} produced no audio")
    x = audio.samples
    fs = audio.fs

    def func(t: np.ndarray) -> np.ndarray:
        return x[np.minimum(np.rint(t * fs).astype(np.intp), len(x) - 1)]

    return SimulatedSource(func, fs, realtime=realtime, duration=len(x) / fs,
                           name=f"simulated {scene.name}({name})")
