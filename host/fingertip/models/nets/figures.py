"""The PNG figures the trainers write: matplotlib on the Agg backend (no screen needed),
imported only when a figure is drawn, and one way to save a figure and free it."""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from ...outputs import atomic_output


def pyplot() -> Any:
    """``matplotlib.pyplot`` on the Agg backend, unless the caller already chose one
    (``force=False``: a notebook keeps its own)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def save_png(fig: Any, path: str | os.PathLike, dpi: float | None = None) -> Path:
    """Lay out ``fig``, write it to ``path`` (making its folder) at ``dpi`` (the figure's
    own by default) and close it, so that a training run that draws many figures does not
    keep them all in memory."""
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(path) as tmp:
        fig.savefig(tmp, dpi="figure" if dpi is None else dpi, format=path.suffix[1:] or "png")
    pyplot().close(fig)
    return path
