"""The host package's layers (docs/design.md): no module imports a package of its own rank or
above, including imports inside functions, which a reader of a module's head never sees.

The layer table is read from docs/design.md itself, so the map and the rule cannot drift."""
from __future__ import annotations

import ast
import re
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "host" / "fingertip"
DESIGN = ROOT / "docs" / "design.md"


@dataclass(frozen=True)
class Violation:
    module: str
    line: int
    imported: str
    why: str

    def __str__(self) -> str:
        return f"{self.module}:{self.line} imports {self.imported}: {self.why}"


def read_layers(design: Path) -> dict[str, int]:
    """Package -> rank, from the table rows ``| rank | `a`, `b` | ...`` of docs/design.md."""
    ranks: dict[str, int] = {}
    for line in design.read_text().splitlines():
        m = re.match(r"\|\s*(\d+)\s*\|([^|]*)\|", line)
        if not m:
            continue
        for name in re.findall(r"`([A-Za-z_][A-Za-z0-9_]*)`", m.group(2)):
            if name in ranks:
                raise ValueError(f"{design}: {name} is listed in two rows")
            ranks[name] = int(m.group(1))
    return ranks


def _module_name(path: Path, package: Path) -> tuple[list[str], bool]:
    parts = list(path.relative_to(package.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        return parts[:-1], True
    return parts, False


def imports_of(path: Path, package: Path) -> list[tuple[int, list[str]]]:
    """Every import of the package made anywhere in ``path`` (module head, functions,
    ``TYPE_CHECKING`` blocks), as absolute dotted parts; ``from . import x`` gives
    ``[..., "x"]`` since ``x`` may be a module."""
    name, is_pkg = _module_name(path, package)
    here = name if is_pkg else name[:-1]
    out: list[tuple[int, list[str]]] = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name.split(".")) for a in node.names
                    if a.name.split(".")[0] == package.name]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[:len(here) - (node.level - 1)]
            elif node.module and node.module.split(".")[0] == package.name:
                base = []
            else:
                continue
            target = base + (node.module.split(".") if node.module else [])
            if node.module is None:
                out += [(node.lineno, target + [a.name]) for a in node.names]
            else:
                out.append((node.lineno, target))
    return out


SIM_ORDER = ("physics", "device", "world", "mujoco")
"""Inside ``sim``, each sub-package may import only itself and those before it here."""


def _sim_inner(name: list[str], target: list[str]) -> str | None:
    """Why an import inside ``sim`` goes up its inner order (docs/design.md), else None."""
    here = name[2] if name[1:2] == ["sim"] and len(name) > 2 else None
    if here not in SIM_ORDER or target[1:2] != ["sim"]:
        return None
    there = target[2] if len(target) > 2 else None
    if here == "physics" and there != "physics":
        return "sim.physics is the bottom of sim"
    if there in SIM_ORDER and SIM_ORDER.index(there) > SIM_ORDER.index(here):
        return f"sim.{there} is above sim.{here}"
    return None


def check_layers(package: Path, ranks: dict[str, int]) -> tuple[list[Violation], list[str]]:
    """The upward imports in ``package``, and its top-level names that no row places."""
    unplaced = sorted({p.relative_to(package).parts[0].removesuffix(".py")
                       for p in package.rglob("*.py")} - set(ranks) - {"__init__"})
    bad: list[Violation] = []
    for path in sorted(package.rglob("*.py")):
        name, _ = _module_name(path, package)
        if len(name) < 2:
            continue  # the root facade re-exports the public names of the lower layers
        src = name[1]
        for line, target in imports_of(path, package):
            if len(target) < 2 or target[1] in ("__version__",):
                continue  # `from .. import __version__`: any layer may read the version
            dst = target[1]
            mod = ".".join(name)
            why = _sim_inner(name, target)
            if why:
                bad.append(Violation(mod, line, ".".join(target), why))
            if dst == src or dst not in ranks or src not in ranks:
                continue
            if ranks[dst] >= ranks[src]:
                bad.append(Violation(mod, line, ".".join(target),
                                     f"{dst} (rank {ranks[dst]}) is not below {src} "
                                     f"(rank {ranks[src]})"))
    return bad, unplaced


def test_no_module_imports_its_own_rank_or_above():
    bad, unplaced = check_layers(PACKAGE, read_layers(DESIGN))
    assert not unplaced, f"give these a row in docs/design.md: {unplaced}"
    assert not bad, "upward imports:\n" + "\n".join(map(str, bad))


def test_the_tasks_never_import_the_simulator():
    """The recipes run unchanged on a real robot (issue 15, item 2)."""
    hits = [(p, line) for p in (PACKAGE / "tasks").rglob("*.py")
            for line, target in imports_of(p, PACKAGE) if target[1:2] == ["sim"]]
    assert not hits


def _tree(tmp_path: Path, files: dict[str, str]) -> Path:
    pkg = tmp_path / "fingertip"
    for rel, text in files.items():
        f = pkg / rel
        f.parent.mkdir(parents=True, exist_ok=True)
        f.write_text(text)
    return pkg


@pytest.mark.parametrize("text", [
    "from ..sim import world\n",
    "def f():\n    from ..sim.world import hand\n",
    "def f():\n    import fingertip.sim\n",
    "from fingertip.sim.world.hand import SimHand\n",
    "from .. import sim\n",
])
def test_the_checker_finds_an_upward_import_wherever_it_hides(tmp_path, text):
    pkg = _tree(tmp_path, {"__init__.py": "", "tasks/__init__.py": "", "sim/__init__.py": "",
                           "sim/world/__init__.py": "", "tasks/pinch.py": text})
    bad, _ = check_layers(pkg, {"tasks": 5, "sim": 6})
    assert [(v.module, v.line) for v in bad] == [("fingertip.tasks.pinch", text.count("\n"))]


def test_the_checker_accepts_downward_imports_and_names_unplaced_packages(tmp_path):
    pkg = _tree(tmp_path, {"__init__.py": "", "sim/__init__.py": "from ..tasks import pinch\n",
                           "tasks/__init__.py": "from .. import __version__\n",
                           "tasks/pinch.py": "", "newpkg/__init__.py": ""})
    assert check_layers(pkg, {"tasks": 5, "sim": 6}) == ([], ["newpkg"])


def test_the_checker_keeps_sim_physics_at_the_bottom_of_sim(tmp_path):
    pkg = _tree(tmp_path, {"__init__.py": "", "sim/__init__.py": "",
                           "sim/physics/__init__.py": "from ..world import hand\n",
                           "sim/world/__init__.py": ""})
    bad, _ = check_layers(pkg, {"sim": 6})
    assert [v.why for v in bad] == ["sim.physics is the bottom of sim"]


@pytest.mark.parametrize("text, why", [
    ("from ..world import hand\n", "sim.world is above sim.device"),
    ("def f():\n    from ..mujoco import scene\n", "sim.mujoco is above sim.device"),
    ("from ..physics import strain\n", None),
])
def test_the_checker_keeps_the_order_inside_sim(tmp_path, text, why):
    """physics < device < world < mujoco: the virtual device never reaches into the world."""
    pkg = _tree(tmp_path, {"__init__.py": "", "sim/__init__.py": "", "sim/device/__init__.py": "",
                           "sim/device/pty.py": text, "sim/physics/__init__.py": "",
                           "sim/world/__init__.py": "", "sim/mujoco/__init__.py": ""})
    bad, _ = check_layers(pkg, {"sim": 6})
    assert [v.why for v in bad] == ([why] if why else [])


def test_a_package_in_two_rows_is_refused(tmp_path):
    doc = tmp_path / "design.md"
    doc.write_text("| 0 | `protocol` | x |\n| 1 | `protocol`, `device` | y |\n")
    with pytest.raises(ValueError, match="protocol is listed in two rows"):
        read_layers(doc)
