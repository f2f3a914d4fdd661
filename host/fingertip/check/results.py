"""What a bring-up check found: one :class:`Result` per check (and channel), a :class:`Report`
with the table, the JSON and the exit code."""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

PASS, WARN, FAIL, SKIP = "pass", "warn", "fail", "skip"
ORDER = {PASS: 0, SKIP: 1, WARN: 2, FAIL: 3}


@dataclass
class Result:
    """One check. ``value``/``limit``: the number measured and what it was held against
    (human-readable); ``fault``: the build fault it points at (a stable name, the same as the
    simulator's, or ""); ``fix``: one line telling what to do (failures and warnings)."""

    check: str
    status: str
    value: str = ""
    limit: str = ""
    channel: int | None = None
    fault: str = ""
    fix: str = ""
    data: dict[str, Any] = field(default_factory=dict)

    @property
    def where(self) -> str:
        return "-" if self.channel is None else f"ch{self.channel}"


@dataclass
class Report:
    results: list[Result] = field(default_factory=list)
    device: dict[str, Any] = field(default_factory=dict)
    skipped_steps: list[str] = field(default_factory=list)
    seconds: float = 0.0
    mapping: dict[str, Any] | None = None
    recorded: dict[str, Any] = field(default_factory=dict, repr=False)
    """What was recorded (the rest segment, the press responses) for :mod:`.plot`; not in
    the JSON."""

    def add(self, r: Result | list[Result]) -> None:
        self.results.extend(r if isinstance(r, list) else [r])

    @property
    def failures(self) -> list[Result]:
        return [r for r in self.results if r.status == FAIL]

    @property
    def warnings(self) -> list[Result]:
        return [r for r in self.results if r.status == WARN]

    @property
    def faults(self) -> set[str]:
        """The build faults the failed checks name."""
        return {r.fault for r in self.failures if r.fault}

    @property
    def ok(self) -> bool:
        return not self.failures

    def exit_code(self) -> int:
        return 0 if self.ok else 1

    def table(self) -> str:
        rows = [("check", "where", "status", "measured", "limit")]
        for r in self.results:
            rows.append((r.check, r.where, r.status.upper(), r.value, r.limit))
        w = [max(len(row[i]) for row in rows) for i in range(5)]
        lines = ["  ".join(c.ljust(w[i]) for i, c in enumerate(row)).rstrip() for row in rows]
        lines.insert(1, "  ".join("-" * x for x in w))
        fixes = [r for r in self.results if r.status in (FAIL, WARN) and r.fix]
        if fixes:
            lines.append("")
            for r in fixes:
                lines.append(f"{r.status.upper()} {r.check} {r.where}: {r.fix}")
        if self.skipped_steps:
            lines.append("")
            lines.append("skipped (--no-prompt): " + "; ".join(self.skipped_steps))
        n = {s: sum(r.status == s for r in self.results) for s in ORDER}
        lines.append("")
        lines.append(f"{n[PASS]} passed, {n[WARN]} warnings, {n[FAIL]} failed, {n[SKIP]} "
                     f"skipped in {self.seconds:.1f} s")
        return "\n".join(lines)

    def as_dict(self) -> dict[str, Any]:
        return {"ok": self.ok, "seconds": round(self.seconds, 2), "device": self.device,
                "faults": sorted(self.faults), "skipped_steps": self.skipped_steps,
                "mapping": self.mapping, "results": [asdict(r) for r in self.results]}

    def write_json(self, path: str | Path) -> Path:
        p = Path(path)
        p.write_text(json.dumps(self.as_dict(), indent=1, default=_jsonable) + "\n",
                     encoding="utf-8")
        return p


def _jsonable(o: Any) -> Any:
    try:
        return o.tolist()
    except AttributeError:
        return str(o)
