"""The one strict reader of the project's parameter files: TOML tables -> frozen dataclasses.

The fingertip's parts (``fingertip.toml``, here) and the simulator's error sources
(``sim/physics/realism.toml``) are read by the same rules: a ``schema`` number, one table per
dataclass, field names equal to the keys, lists turned into tuples, and every unknown or missing
table or key an error naming the file, so a file and its code cannot drift apart silently.

Standard library only: the PCB generator loads this package by path, outside any environment.
"""
from __future__ import annotations

from dataclasses import fields
from typing import Any

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: the same parser as the tomli package
    import tomli as tomllib  # type: ignore[no-redef]

__all__ = ["build", "read_tables", "tomllib"]


def build(cls: type, table: dict[str, Any], where: str) -> Any:
    """``cls(**table)``, refusing unknown and missing keys; lists become tuples."""
    names = {f.name for f in fields(cls)}
    unknown, missing = set(table) - names, names - set(table)
    if unknown or missing:
        raise ValueError(f"{where}: unknown keys {sorted(unknown)}, missing keys {sorted(missing)}")
    return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in table.items()})


def read_tables(data: dict[str, Any], sections: dict[str, type], where: str,
                schema: int) -> dict[str, Any]:
    """``{name: sections[name](**data[name])}`` for a parsed file with ``schema = schema``
    and exactly the tables of ``sections``."""
    if data.get("schema") != schema:
        raise ValueError(f"{where}: schema {data.get('schema')!r}, expected {schema}")
    tables = {k: v for k, v in data.items() if k != "schema"}
    unknown, missing = set(tables) - set(sections), set(sections) - set(tables)
    if unknown or missing:
        raise ValueError(f"{where}: unknown tables {sorted(unknown)}, "
                         f"missing tables {sorted(missing)}")
    return {name: build(cls, tables[name], f"{where} [{name}]")
            for name, cls in sections.items()}
