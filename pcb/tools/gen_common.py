# ruff: noqa: E501  (templates of KiCad files: one line per KiCad item)
"""Shared helpers of the board generators (run with /usr/bin/python3: pcbnew is there)."""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

from sexpr import find, find_all, parse

FP_LIB_TABLE = """(fp_lib_table
\t(version 7)
\t(lib (name "{name}") (type "KiCad") (uri "${{KIPRJMOD}}/{name}.pretty") (options "") (descr "{descr}"))
)
"""

SYM_LIB_TABLE = """(sym_lib_table
\t(version 7)
)
"""


def netlist(sch: Path) -> dict[tuple[str, str], str]:
    """(ref, pin) -> net name, from `kicad-cli sch export netlist` (names exactly as KiCad)."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "net.net"
        subprocess.run(["kicad-cli", "sch", "export", "netlist", "--format", "kicadsexpr",
                        "-o", str(out), str(sch)], check=True, capture_output=True)
        tree = parse(out.read_text(encoding="utf-8"))
    res = {}
    for net in find_all(find(tree, "nets"), "net"):
        name = str(find(net, "name")[1])
        for node in find_all(net, "node"):
            res[(str(find(node, "ref")[1]), str(find(node, "pin")[1]))] = name
    return res


def write_project_files(folder: Path, name: str, fp_lib: str | None, descr: str = "") -> None:
    if fp_lib:
        (folder / "fp-lib-table").write_text(FP_LIB_TABLE.format(name=fp_lib, descr=descr),
                                             encoding="utf-8")


def finish_project(pro: Path, root_uuid: str, severities: dict[str, str] | None = None) -> None:
    """Make the .kicad_pro written by pcbnew stable and add what the schematic needs."""
    d = json.loads(pro.read_text(encoding="utf-8"))
    d.setdefault("meta", {})["filename"] = pro.name
    rs = d["board"]["design_settings"].setdefault("rule_severities", {})
    rs.update(severities or {})
    d["sheets"] = [[root_uuid, "Root"]]
    pro.write_text(json.dumps(d, indent=2, sort_keys=True) + "\n", encoding="utf-8")


WIRE_PAD_MOD = """(footprint "{name}"
\t(version 20241229)
\t(generator "fingertip_pcbgen")
\t(layer "F.Cu")
\t(descr "Solder pad for a sensor lead ({size} mm square), no courtyard margin beyond 0.1 mm")
\t(attr smd exclude_from_bom)
\t(property "Reference" "REF**" (at 0 -1 0) (layer "F.SilkS") (hide yes)
\t\t(effects (font (size 0.5 0.5) (thickness 0.08))))
\t(property "Value" "{name}" (at 0 1 0) (layer "F.Fab")
\t\t(effects (font (size 0.4 0.4) (thickness 0.06))))
\t(fp_rect (start {c0} {c0}) (end {c1} {c1}) (stroke (width 0.05) (type solid)) (fill no) (layer "F.CrtYd"))
\t(pad "1" smd roundrect (at 0 0) (size {size} {size}) (layers "F.Cu" "F.Mask" "F.Paste")
\t\t(roundrect_rratio 0.15))
)
"""

HOLE_MOD = """(footprint "{name}"
\t(version 20241229)
\t(generator "fingertip_pcbgen")
\t(layer "F.Cu")
\t(descr "M2 clearance hole {d} mm, non-plated. No courtyard: the FFC connector's IPC courtyard (its mounting tabs + 0.5 mm) reaches the hole edge; copper keeps the hole clearance (DRC)")
\t(attr exclude_from_pos_files exclude_from_bom)
\t(property "Reference" "REF**" (at 0 -1.8 0) (layer "F.SilkS") (hide yes)
\t\t(effects (font (size 0.5 0.5) (thickness 0.08))))
\t(property "Value" "{name}" (at 0 1.8 0) (layer "F.Fab")
\t\t(effects (font (size 0.4 0.4) (thickness 0.06))))
\t(fp_circle (center 0 0) (end {r} 0) (stroke (width 0.1) (type solid)) (fill no) (layer "F.Fab"))
\t(pad "" np_thru_hole circle (at 0 0) (size {d} {d}) (drill {d}) (layers "*.Cu" "*.Mask"))
)
"""


def write_wire_pad(lib: Path, name: str, size: float, court: float) -> None:
    lib.mkdir(parents=True, exist_ok=True)
    c = round(size / 2 + court, 3)
    (lib / f"{name}.kicad_mod").write_text(
        WIRE_PAD_MOD.format(name=name, size=size, c0=-c, c1=c), encoding="utf-8")


def write_hole(lib: Path, name: str, d: float) -> None:
    lib.mkdir(parents=True, exist_ok=True)
    (lib / f"{name}.kicad_mod").write_text(HOLE_MOD.format(name=name, d=d, r=round(d / 2, 4)),
                                           encoding="utf-8")


def generator_main(doc: str, name: str, default_out: Path, build) -> int:
    """The command line of a shield generator: ``--out DIR``; exit 1 with what did not
    route."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--out", default=str(default_out), help="project folder")
    a = ap.parse_args()
    failed = build(Path(a.out))
    if failed:
        print("unrouted: " + ", ".join(failed), file=sys.stderr)
        return 1
    print(f"{name} board written to {a.out}")
    return 0
