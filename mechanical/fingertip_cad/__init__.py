"""Parametric CAD of the fingertip: base, prism, cap with fingernail, skin and two-part mold.

Every dimension comes from the one parameter file shared with the virtual fingertip
(``fingertip.hardware.params``, ``fingertip.toml``): :mod:`.config` loads it (optionally
from another path and with ``section.key=value`` overrides) and :mod:`.dims` turns it into the
derived dimensions the parts use. CadQuery is imported only by the modules that build solids
(never by the ``fingertip`` host package), so the host install stays small.

Frame: origin on the prism axis in the base's underside plane, +z up, +x the outward normal of
channel 0's face (the nail's side), the same frame as the ``[mount]`` section.
"""
from __future__ import annotations

from .config import load_params
from .dims import Dims

__all__ = ["Dims", "load_params"]
