"""The fingertip's parameters for the CAD: the shipped TOML, another file, and overrides.

Overrides are ``section.key=value`` strings (values parsed as TOML, so ``22`` is a number and
``[1, 2]`` a list), applied before the loader's own checks, so an impossible set fails with the
same clear message as a bad file.
"""
from __future__ import annotations

import copy
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from fingertip.hardware.params import FingertipParams, from_dict, params_path

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]


def parse_override(text: str) -> tuple[str, str, Any]:
    """``"geometry.outer_width_mm=22"`` -> ``("geometry", "outer_width_mm", 22)``."""
    key, sep, raw = text.partition("=")
    section, dot, name = key.strip().partition(".")
    if not sep or not dot or not section or not name:
        raise ValueError(f"override {text!r}: expected section.key=value")
    try:
        value = tomllib.loads(f"v = {raw.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw.strip()  # a bare word: a string
    return section, name, value


def load_params(path: str | Path | None = None,
                overrides: Iterable[str] | Mapping[str, Any] = ()) -> FingertipParams:
    """Load ``path`` (default: the shipped file) with ``overrides`` applied, then check it."""
    source = Path(path) if path is not None else params_path()
    data = tomllib.loads(source.read_text(encoding="utf-8"))
    data = copy.deepcopy(data)
    items = overrides.items() if isinstance(overrides, Mapping) else \
        ((f"{s}.{k}", v) for s, k, v in map(parse_override, overrides))
    for dotted, value in items:
        section, _, name = dotted.partition(".")
        table = data.get(section)
        if not isinstance(table, dict) or name not in table:
            raise ValueError(f"override {dotted!r}: no such key in {source.name}")
        table[name] = value
    return from_dict(data, str(source))
