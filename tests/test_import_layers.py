"""The host package's layers (docs/design.md): no module imports a package of its own rank or
above, and no package's modules import one another in a circle.

An import counts wherever it hides from a reader of a module's head: inside functions, in
``TYPE_CHECKING`` blocks, as ``from fingertip import sim``, as a name the root
``fingertip/__init__.py`` re-exports (``from fingertip import Fingertip`` is an import of
``device``), and as ``importlib.import_module("fingertip.sim")`` with a literal name.

The layer table is read from docs/design.md itself, so the map and the rule cannot drift."""
from __future__ import annotations

import ast
import re
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import pytest

ROOT = Path(__file__).resolve().parents[1]
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


class Import(NamedTuple):
    line: int
    target: list[str]  # absolute dotted parts: a module, or a module and a name in it
    module_level: bool  # run when the module is imported (not inside a function)


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


def _import_module_call(node: ast.Call, name: list[str], here: list[str],
                        top: str) -> list[str] | None:
    """The module that ``importlib.import_module("...")`` (or ``import_module``,
    ``__import__``) loads when its name is a literal string; relative names are resolved
    against ``__package__`` or ``__name__``."""
    f = node.func
    if not (isinstance(f, ast.Attribute) and f.attr == "import_module"
            and isinstance(f.value, ast.Name) and f.value.id == "importlib"
            or isinstance(f, ast.Name) and f.id in ("import_module", "__import__")):
        return None
    if not node.args or not isinstance(node.args[0], ast.Constant) \
            or not isinstance(node.args[0].value, str):
        return None
    text = node.args[0].value
    rest = text.lstrip(".")
    level = len(text) - len(rest)
    if not level:
        parts = text.split(".")
        return parts if parts[0] == top else None
    anchor = node.args[1] if len(node.args) > 1 else next(
        (k.value for k in node.keywords if k.arg == "package"), None)
    if not isinstance(anchor, ast.Name) or anchor.id not in ("__package__", "__name__"):
        return None
    base = here if anchor.id == "__package__" else name
    base = base[:len(base) - (level - 1)]
    return base + (rest.split(".") if rest else [])


def _from_module(node: ast.ImportFrom, here: list[str], top: str) -> list[str] | None:
    """The absolute module of ``from MODULE import ...`` in package ``here``; None when it
    is outside the package ``top``."""
    if node.level:
        base = here[:len(here) - (node.level - 1)]
    elif node.module and node.module.split(".")[0] == top:
        base = []
    else:
        return None
    return base + (node.module.split(".") if node.module else [])


class _Finder(ast.NodeVisitor):
    """Collects every import of the package in one module, noting whether it runs when the
    module is imported (class bodies do; function bodies do not)."""

    def __init__(self, name: list[str], here: list[str], top: str, roots: set[str]) -> None:
        self.name, self.here, self.top, self.roots = name, here, top, roots
        self.depth = 0
        self.found: list[Import] = []

    def _add(self, node: ast.AST, target: list[str]) -> None:
        self.found.append(Import(node.lineno, target, self.depth == 0))

    def _function(self, node: ast.AST) -> None:
        self.depth += 1
        self.generic_visit(node)
        self.depth -= 1

    visit_FunctionDef = visit_AsyncFunctionDef = visit_Lambda = _function

    def visit_Import(self, node: ast.Import) -> None:
        for a in node.names:
            if a.name.split(".")[0] == self.top:
                self._add(node, a.name.split("."))

    def visit_ImportFrom(self, node: ast.ImportFrom) -> None:
        target = _from_module(node, self.here, self.top)
        # `from fingertip import sim`, `from . import frames`: each name may be a module.
        for a in node.names if target is not None else ():
            self._add(node, target + [a.name])

    def visit_Attribute(self, node: ast.Attribute) -> None:
        # `import fingertip` then `fingertip.Fingertip(...)`: a name reached through the root.
        if isinstance(node.value, ast.Name) and node.value.id in self.roots:
            self._add(node, [self.top, node.attr])
        self.generic_visit(node)

    def visit_Call(self, node: ast.Call) -> None:
        target = _import_module_call(node, self.name, self.here, self.top)
        if target is not None:
            self._add(node, target)
        self.generic_visit(node)


def _names_bound_to_the_root(tree: ast.AST, top: str) -> set[str]:
    """Names through which a module reads attributes of the root package: ``fingertip`` after
    ``import fingertip[.x]``, ``ft`` after ``import fingertip as ft``."""
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.asname is None and a.name.split(".")[0] == top:
                    names.add(top)
                elif a.asname is not None and a.name == top:
                    names.add(a.asname)
    return names


def imports_of(path: Path, package: Path) -> list[Import]:
    """Every import of the package made anywhere in ``path``, as absolute dotted parts;
    ``from . import x`` gives ``[..., "x"]`` since ``x`` may be a module."""
    name, is_pkg = _module_name(path, package)
    here = name if is_pkg else name[:-1]
    tree = ast.parse(path.read_text(), str(path))
    finder = _Finder(name, here, package.name, _names_bound_to_the_root(tree, package.name))
    finder.visit(tree)
    return finder.found


def root_exports(package: Path) -> dict[str, list[str]]:
    """The names that the root ``__init__.py`` imports from the package (its facade), each
    with where it comes from: ``{"Fingertip": ["fingertip", "device", "Fingertip"]}``."""
    init = package / "__init__.py"
    if not init.exists():
        return {}
    out: dict[str, list[str]] = {}
    for node in ast.walk(ast.parse(init.read_text(), str(init))):
        if isinstance(node, ast.ImportFrom):
            base = _from_module(node, [package.name], package.name)
            for a in node.names if base is not None else ():
                out[a.asname or a.name] = base + [a.name]
        elif isinstance(node, ast.Assign) and any(
                isinstance(t, ast.Name) and t.id == "_LAZY" for t in node.targets):
            # Names the root imports on first use (``__getattr__``): {name: "sub.module"}.
            lazy = ast.literal_eval(node.value)
            for name, where in lazy.items():
                out[name] = [package.name, *where.split("."), name]
    return out


def _through_the_root(target: list[str], exports: dict[str, list[str]]) -> list[str]:
    """``fingertip.Fingertip`` is ``fingertip.device.Fingertip``: the package it comes from."""
    if len(target) >= 2 and target[1] in exports:
        return exports[target[1]] + target[2:]
    return target


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
    exports = root_exports(package)
    bad: list[Violation] = []
    for path in sorted(package.rglob("*.py")):
        name, _ = _module_name(path, package)
        if len(name) < 2:
            continue  # the root facade re-exports the public names of the lower layers
        src = name[1]
        mod = ".".join(name)
        seen: set[tuple[int, str]] = set()
        for imp in imports_of(path, package):
            target = _through_the_root(imp.target, exports)
            if len(target) < 2 or target[1] in ("__version__",):
                continue  # `from .. import __version__`: any layer may read the version
            dst = target[1]
            if (imp.line, dst) in seen:
                continue  # `from ..sim import a, b`: one upward import
            seen.add((imp.line, dst))
            why = _sim_inner(name, target)
            if why:
                bad.append(Violation(mod, imp.line, ".".join(target), why))
            if dst == src or dst not in ranks or src not in ranks:
                continue
            if ranks[dst] >= ranks[src]:
                bad.append(Violation(mod, imp.line, ".".join(target),
                                     f"{dst} (rank {ranks[dst]}) is not below {src} "
                                     f"(rank {ranks[src]})"))
    return bad, unplaced


def import_cycles(package: Path) -> list[list[str]]:
    """Circles of module-level imports (``TYPE_CHECKING`` ones too: a module that needs
    another's type for its own cannot be read apart from it) between the modules of one
    package of the table; each circle as its sorted module names. Imports inside functions
    are left out: they run late, and the layer rule above already limits where they reach."""
    modules = {".".join(_module_name(p, package)[0]): p for p in package.rglob("*.py")}
    edges: dict[str, set[str]] = {m: set() for m in modules}
    for mod, path in modules.items():
        parts = mod.split(".")
        if len(parts) < 2:
            continue  # the root facade belongs to no one package
        for imp in imports_of(path, package):
            if not imp.module_level:
                continue
            # The longest prefix that is a module: `fingertip.device.frames.Frame` is frames.
            dst = next((".".join(imp.target[:n]) for n in range(len(imp.target), 1, -1)
                        if ".".join(imp.target[:n]) in modules), None)
            if dst is not None and dst != mod and dst.split(".")[1] == parts[1]:
                edges[mod].add(dst)
    return _strongly_connected(edges)


def _strongly_connected(edges: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's algorithm: the components of more than one node, each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(edges[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp: list[str] = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return sorted(out)


def test_no_module_imports_its_own_rank_or_above():
    bad, unplaced = check_layers(PACKAGE, read_layers(DESIGN))
    assert not unplaced, f"give these a row in docs/design.md: {unplaced}"
    assert not bad, "upward imports:\n" + "\n".join(map(str, bad))


def test_no_package_imports_itself_in_a_circle():
    cycles = import_cycles(PACKAGE)
    assert not cycles, "module-level import cycles:\n" + "\n".join(map(" <-> ".join, cycles))


def test_the_tasks_never_import_the_simulator():
    """The recipes run unchanged on a real robot (issue 15, item 2)."""
    exports = root_exports(PACKAGE)
    hits = [(p, imp.line) for p in (PACKAGE / "tasks").rglob("*.py")
            for imp in imports_of(p, PACKAGE)
            if _through_the_root(imp.target, exports)[1:2] == ["sim"]]
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
    "from ..sim import world, physics\n",
    # a package imported by name from the root
    "from fingertip import sim\n",
    "def f():\n    from fingertip import sim as s\n",
    # importlib with a literal name, absolute or relative
    "import importlib\nimportlib.import_module('fingertip.sim.world')\n",
    "from importlib import import_module\n\ndef f():\n    import_module('..sim', __package__)\n",
    "import importlib\nM = importlib.import_module(name='.world', package=__name__)\n"
    "N = importlib.import_module('...sim', package=__name__)\n",
    "__import__('fingertip.sim')\n",
])
def test_the_checker_finds_an_upward_import_wherever_it_hides(tmp_path, text):
    pkg = _tree(tmp_path, {"__init__.py": "", "tasks/__init__.py": "", "sim/__init__.py": "",
                           "sim/world/__init__.py": "", "tasks/pinch.py": text})
    bad, _ = check_layers(pkg, {"tasks": 5, "sim": 6})
    assert [(v.module, v.line) for v in bad] == [("fingertip.tasks.pinch", text.count("\n"))]


@pytest.mark.parametrize("text", [
    "from fingertip import Fingertip\n",
    "from .. import Fingertip as F\n",
    "import fingertip\n\ndef f():\n    return fingertip.Fingertip\n",
    "import fingertip as ft\nPORT = ft.Fingertip\n",
])
@pytest.mark.parametrize("root", ["from .device import Fingertip\n",
                                  "_LAZY = {'Fingertip': 'device'}\n"])
def test_a_name_reached_through_the_root_counts_as_its_package(tmp_path, text, root):
    """The root re-exports `Fingertip` from `device` (imported, or on first use through
    `_LAZY`): a transport reading it imports device."""
    pkg = _tree(tmp_path, {"__init__.py": root,
                           "device/__init__.py": "class Fingertip: ...\n",
                           "transport/__init__.py": "", "transport/serial.py": text})
    bad, _ = check_layers(pkg, {"transport": 1, "device": 2})
    assert [(v.line, v.imported) for v in bad] == [
        (text.count("\n"), "fingertip.device.Fingertip")]


def test_the_checker_accepts_downward_imports_and_names_unplaced_packages(tmp_path):
    pkg = _tree(tmp_path, {"__init__.py": "from .tasks import pinch\n",
                           "sim/__init__.py": "from ..tasks import pinch\n"
                                              "from fingertip import pinch as p\n"
                                              "import importlib\n"
                                              "importlib.import_module(f'.{p}', __name__)\n",
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


FT, FRAMES = "fingertip.device.fingertip", "fingertip.device.frames"


@pytest.mark.parametrize("head, other, cycle", [
    ("from . import frames\n", "from .fingertip import Fingertip\n", [FT, FRAMES]),
    ("from .frames import Frame\n", "from fingertip.device.reader import Reader\n",
     [FRAMES, "fingertip.device.reader"]),
    ("from .frames import Frame\n",
     "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .fingertip import F\n",
     [FT, FRAMES]),
    ("from .frames import Frame\n", "class Frame:\n    from . import fingertip\n",
     [FT, FRAMES]),
    ("from .frames import Frame\n", "from .. import device\n",
     ["fingertip.device", FT, FRAMES]),
])
def test_the_checker_finds_an_import_cycle_inside_a_package(tmp_path, head, other, cycle):
    pkg = _tree(tmp_path, {"__init__.py": "", "device/__init__.py": "from . import fingertip\n",
                           "device/fingertip.py": head, "device/frames.py": other,
                           "device/reader.py": "from .frames import Frame\n"})
    assert import_cycles(pkg) == [cycle]


def test_imports_inside_functions_and_across_packages_make_no_cycle(tmp_path):
    pkg = _tree(tmp_path, {"__init__.py": "from .device import Fingertip\n",
                           "device/__init__.py": "from .fingertip import Fingertip\n",
                           "device/fingertip.py": "from .frames import Frame\n",
                           "device/frames.py": "def f():\n    from .fingertip import F\n",
                           "record/__init__.py": "from ..device import Fingertip\n"
                                                 "from fingertip import __version__\n"})
    assert import_cycles(pkg) == []


def test_a_package_in_two_rows_is_refused(tmp_path):
    doc = tmp_path / "design.md"
    doc.write_text("| 0 | `protocol` | x |\n| 1 | `protocol`, `device` | y |\n")
    with pytest.raises(ValueError, match="protocol is listed in two rows"):
        read_layers(doc)


def test_the_real_root_names_the_packages_of_its_public_names():
    """The real facade loads its names on first use: the checker must still see where each
    comes from, or `from fingertip import Fingertip` in a low layer would pass unseen."""
    exports = root_exports(PACKAGE)
    assert exports["Fingertip"] == ["fingertip", "device", "Fingertip"]
    assert exports["ProtocolVersionError"] == ["fingertip", "protocol", "ProtocolVersionError"]
