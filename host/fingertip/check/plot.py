"""A picture of what the check recorded: the rest (noise per channel) and each guided
press's change of the four channels, against the pattern a correct build gives."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..outputs import atomic_output
from .signals import FACES, expected_response


def plot_check(rest, responses: dict, path: str | Path, title: str = "") -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    a = ax[0]
    t = rest.times_s - rest.times_s[0] if len(rest) else np.zeros(0)
    for ch in range(rest.channels):
        v = rest.counts[:, ch]
        a.plot(t, v - np.nanmedian(v), lw=0.7, label=f"ch{ch}")
    a.set_xlabel("time (s)")
    a.set_ylabel("counts - median (untared)")
    a.set_title("at rest: noise of each channel")
    a.legend(fontsize=8)
    a.grid(alpha=0.3)
    a = ax[1]
    faces = sorted(responses)
    width = 0.18
    for ch in range(4):
        got = [responses[f][ch] if responses[f] is not None else 0.0 for f in faces]
        scale = max((np.max(np.abs(r)) for r in responses.values() if r is not None),
                    default=1.0)
        a.bar(np.arange(len(faces)) + (ch - 1.5) * width, np.asarray(got) / scale, width,
              label=f"ch{ch}")
        exp = [expected_response(f)[ch] for f in faces]
        a.scatter(np.arange(len(faces)) + (ch - 1.5) * width, exp, marker="_", s=200,
                  color="k", zorder=3)
    a.set_xticks(np.arange(len(faces)), [f"press {FACES[f]}" for f in faces])
    a.set_ylabel("change / largest change")
    a.set_title("guided presses (black: a correct build)")
    a.axhline(0, color="k", lw=0.5)
    a.legend(fontsize=8)
    a.grid(alpha=0.3, axis="y")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    with atomic_output(path) as tmp:
        fig.savefig(tmp, dpi=90, format=Path(path).suffix[1:] or "png")
    plt.close(fig)
    return Path(path)
