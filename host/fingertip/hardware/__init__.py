"""The fingertip's hardware: its dimensions and parts, one truth for the simulator, the CAD and
the PCB generator (``fingertip.toml`` and its loader, :mod:`.params`; the strict TOML reader
every parameter file of the project goes through, :mod:`.tables`).

Rank 0 of the host package (docs/design.md): standard library only, no I/O but reading the
file, so ``mechanical/`` and ``pcb/tools/`` can read it without the rest of the package.
"""
from .params import FingertipParams, from_dict, load, params_path, section_rigidity

__all__ = ["FingertipParams", "from_dict", "load", "params_path", "section_rigidity"]
