"""Write a KiCad 9 schematic (.kicad_sch) from a circuit description.

Symbols come from the stock KiCad libraries (embedded in lib_symbols as KiCad does); every
pin gets a net label at its connection point (or a no-connect flag), so the schematic is
the netlist, drawn symbol by symbol. Deterministic UUIDs make regeneration byte-stable.
"""
from __future__ import annotations

import copy
import re
import uuid
from dataclasses import dataclass, field
from pathlib import Path

from sexpr import Q, dump, find, find_all, parse

SYMBOL_DIR = Path("/usr/share/kicad/symbols")
NS = uuid.UUID("6f0e3a52-4d1c-4b7e-9a55-2f1f6c0d9e11")
FONT = ["font", ["size", 1.27, 1.27]]


def uid(*key: object) -> Q:
    return Q(str(uuid.uuid5(NS, "/".join(str(k) for k in key))))


_LIB_CACHE: dict[str, list] = {}


def _library(lib: str) -> list:
    if lib not in _LIB_CACHE:
        _LIB_CACHE[lib] = parse((SYMBOL_DIR / f"{lib}.kicad_sym").read_text(encoding="utf-8"))
    return _LIB_CACHE[lib]


def _raw_symbol(lib: str, name: str) -> list:
    for s in find_all(_library(lib), "symbol"):
        if s[1] == name:
            return s
    raise KeyError(f"{lib}:{name} not in the stock library")


def lib_symbol(lib_id: str) -> list:
    """The symbol as embedded in a schematic: named lib:name, 'extends' flattened."""
    lib, name = lib_id.split(":")
    sym = copy.deepcopy(_raw_symbol(lib, name))
    ext = find(sym, "extends")
    if ext is not None:
        parent = copy.deepcopy(_raw_symbol(lib, ext[1]))
        props = find_all(sym, "property")
        keep = [x for x in sym[2:] if isinstance(x, list) and x[0] in
                ("exclude_from_sim", "in_bom", "on_board")]
        body = []
        for x in parent[2:]:
            if isinstance(x, list) and x[0] == "property":
                continue
            if isinstance(x, list) and x[0] in ("exclude_from_sim", "in_bom", "on_board") and keep:
                continue
            if isinstance(x, list) and x[0] == "symbol":
                x[1] = Q(re.sub("^" + re.escape(ext[1]) + "_", name + "_", x[1]))
            body.append(x)
        head = [x for x in body if not (isinstance(x, list) and x[0] == "symbol")]
        units = [x for x in body if isinstance(x, list) and x[0] == "symbol"]
        sym = ["symbol", Q(name)] + keep + head + props + units
    sym[1] = Q(lib_id)
    return sym


@dataclass
class Pin:
    number: str
    name: str
    kind: str
    x: float
    y: float
    angle: float
    unit: int


def symbol_pins(lib_id: str) -> list[Pin]:
    sym = lib_symbol(lib_id)
    pins = []
    for sub in find_all(sym, "symbol"):
        m = re.match(r".*_(\d+)_(\d+)$", sub[1])
        unit, style = int(m.group(1)), int(m.group(2))
        if style not in (0, 1):
            continue
        for p in find_all(sub, "pin"):
            at = find(p, "at")
            pins.append(Pin(str(find(p, "number")[1]), str(find(p, "name")[1]), p[1],
                            float(at[1]), float(at[2]), float(at[3]) if len(at) > 3 else 0.0,
                            unit))
    return pins


def is_power_symbol(lib_id: str) -> bool:
    return find(lib_symbol(lib_id), "power") is not None


@dataclass
class Part:
    ref: str
    lib_id: str
    value: str
    footprint: str
    nets: dict[str, str | None]          # pin number -> net name (None = no connect)
    at: tuple[float, float] = (0.0, 0.0)  # unit 1; other units to the right
    fields: dict[str, str] = field(default_factory=dict)
    in_bom: bool = True
    unit_at: dict[int, tuple[float, float]] = field(default_factory=dict)


def _grid(v: float) -> float:
    return round(round(v / 1.27) * 1.27, 4)


class Schematic:
    def __init__(self, project: str, title: str, paper: str = "A3", rev: str = "1",
                 comments: tuple[str, ...] = ()):
        self.project = project
        self.title = title
        self.paper = paper
        self.rev = rev
        self.comments = comments
        self.parts: list[Part] = []
        self.flags: list[tuple[str, tuple[float, float]]] = []
        self.notes: list[tuple[str, tuple[float, float], float]] = []

    def add(self, part: Part) -> Part:
        if any(p.ref == part.ref for p in self.parts):
            raise ValueError(f"duplicate reference {part.ref}")
        self.parts.append(part)
        return part

    def power_flag(self, net: str, at: tuple[float, float]) -> None:
        self.flags.append((net, at))

    def note(self, text: str, at: tuple[float, float], size: float = 1.27) -> None:
        self.notes.append((text, at, size))

    # --- netlist view (what the board generator and the checks use) -----------------------
    def nets(self) -> dict[str, list[tuple[str, str]]]:
        out: dict[str, list[tuple[str, str]]] = {}
        for p in self.parts:
            for num, net in p.nets.items():
                if net is not None:
                    out.setdefault(net, []).append((p.ref, num))
        return out

    # --- writing ----------------------------------------------------------------------------
    def _label(self, net: str, x: float, y: float, pin_angle: float, key: str) -> list:
        angle = {0: 180, 180: 0, 90: 270, 270: 90}[int(pin_angle) % 360]
        just = "right" if angle in (180, 270) else "left"
        return ["label", Q(net), ["at", x, y, angle],
                ["effects", FONT, ["justify", just, "bottom"]], ["uuid", uid(key, "label")]]

    def _symbol_instance(self, lib_id: str, ref: str, unit: int, x: float, y: float,
                         props: list[tuple[str, str, bool]], in_bom: bool, on_board: bool,
                         pins: list[Pin], key: str) -> list:
        inst = ["symbol", ["lib_id", Q(lib_id)], ["at", x, y, 0], ["unit", unit],
                ["exclude_from_sim", "no"], ["in_bom", "yes" if in_bom else "no"],
                ["on_board", "yes" if on_board else "no"], ["dnp", "no"],
                ["uuid", uid(key)]]
        dy = -3.81
        for i, (name, value, visible) in enumerate(props):
            eff = ["effects", FONT]
            if not visible:
                eff.append(["hide", "yes"])
            else:
                eff.append(["justify", "left"])
            inst.append(["property", Q(name), Q(value), ["at", x + 2.54, y + dy - 2.54 * i, 0],
                         eff])
        for p in pins:
            inst.append(["pin", Q(p.number), ["uuid", uid(key, "pin", p.number)]])
        inst.append(["instances", ["project", Q(self.project),
                                   ["path", Q("/" + uid(self.project, "root")),
                                    ["reference", Q(ref)], ["unit", unit]]]])
        return inst

    def write(self, path: Path) -> None:
        lib_ids = sorted({p.lib_id for p in self.parts} |
                         ({"power:PWR_FLAG"} if self.flags else set()))
        root = ["kicad_sch", ["version", 20250114], ["generator", Q("fingertip_pcbgen")],
                ["generator_version", Q("9.0")], ["uuid", uid(self.project, "root")],
                ["paper", Q(self.paper)]]
        tb = ["title_block", ["title", Q(self.title)], ["rev", Q(self.rev)],
              ["company", Q("fingertip project (open hardware)")]]
        for i, c in enumerate(self.comments, start=1):
            tb.append(["comment", i, Q(c)])
        root.append(tb)
        root.append(["lib_symbols"] + [lib_symbol(lid) for lid in lib_ids])
        items: list = []
        for text, (x, y), size in self.notes:
            items.append(["text", Q(text), ["exclude_from_sim", "no"], ["at", x, y, 0],
                          ["effects", ["font", ["size", size, size]], ["justify", "left", "top"]],
                          ["uuid", uid(self.project, "note", text[:40], x, y)]])
        for p in self.parts:
            pins = symbol_pins(p.lib_id)
            units = sorted({pin.unit for pin in pins if pin.unit > 0}) or [1]
            numbers = {pin.number for pin in pins}
            unknown = set(p.nets) - numbers
            missing = numbers - set(p.nets)
            if unknown or missing:
                raise ValueError(f"{p.ref} ({p.lib_id}): unknown pins {sorted(unknown)}, "
                                 f"unassigned pins {sorted(missing)}")
            for unit in units:
                ux, uy = p.unit_at.get(unit, (p.at[0] + 30.48 * (unit - 1), p.at[1]))
                ux, uy = _grid(ux), _grid(uy)
                upins = [pin for pin in pins if pin.unit in (0, unit)]
                props = [("Reference", p.ref, True), ("Value", p.value, True),
                         ("Footprint", p.footprint, False), ("Datasheet", "~", False)]
                props += [(k, v, False) for k, v in p.fields.items()]
                key = f"{self.project}/{p.ref}/{unit}"
                items.append(self._symbol_instance(p.lib_id, p.ref, unit, ux, uy, props,
                                                   p.in_bom, True, upins, key))
                for pin in upins:
                    if pin.unit == 0 and unit != units[0]:
                        continue
                    px, py = round(ux + pin.x, 4), round(uy - pin.y, 4)
                    net = p.nets[pin.number]
                    if net is None:
                        items.append(["no_connect", ["at", px, py],
                                      ["uuid", uid(key, "nc", pin.number)]])
                    else:
                        items.append(self._label(net, px, py, pin.angle,
                                                 f"{key}/{pin.number}"))
        for i, (net, (x, y)) in enumerate(self.flags, start=1):
            ref = f"#FLG{i:02d}"
            key = f"{self.project}/{ref}"
            x, y = _grid(x), _grid(y)
            pin = symbol_pins("power:PWR_FLAG")[0]
            items.append(self._symbol_instance(
                "power:PWR_FLAG", ref, 1, x, y,
                [("Reference", ref, False), ("Value", "PWR_FLAG", False),
                 ("Footprint", "", False), ("Datasheet", "~", False)],
                False, True, [pin], key))
            items.append(self._label(net, round(x + pin.x, 4), round(y - pin.y, 4), 90,
                                     key + "/1"))
        root += items
        root.append(["sheet_instances", ["path", Q("/"), ["page", Q("1")]]])
        root.append(["embedded_fonts", "no"])
        path.write_text(dump(root) + "\n", encoding="utf-8")
