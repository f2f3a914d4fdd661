"""KiCad boards: ERC/DRC with kicad-cli 9, footprints, BOM, exports, pin map, mount geometry.

Fails (never skips) when kicad-cli is missing: `make pcb-tools` installs it.
"""
from __future__ import annotations

import csv
import json
import math
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PCB = ROOT / "pcb"
sys.path.insert(0, str(PCB / "tools"))
import fingertip_geometry as geo  # noqa: E402
from sexpr import find, find_all, parse  # noqa: E402

BOARDS = ["fingertip", "readout", "hand"]
SYS_PY = "/usr/bin/python3"


def kicad_cli() -> str:
    exe = shutil.which("kicad-cli")
    assert exe, "kicad-cli (KiCad 9) is missing: run `make pcb-tools`"
    ver = subprocess.run([exe, "version"], capture_output=True, text=True).stdout.strip()
    assert ver.startswith("9."), f"kicad-cli {ver}: KiCad 9 expected"
    return exe


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([kicad_cli(), *args], capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def outdir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("pcb")


@pytest.mark.parametrize("board", BOARDS)
def test_erc_zero_errors(board, outdir):
    out = outdir / f"{board}-erc.json"
    run("sch", "erc", "--format", "json", "-o", str(out), str(PCB / board / f"{board}.kicad_sch"))
    data = json.loads(out.read_text())
    errors = [v for s in data["sheets"] for v in s["violations"] if v["severity"] == "error"]
    assert errors == []


@pytest.mark.parametrize("board", BOARDS)
def test_drc_zero_errors_with_parity(board, outdir):
    out = outdir / f"{board}-drc.json"
    run("pcb", "drc", "--format", "json", "--schematic-parity", "-o", str(out),
        str(PCB / board / f"{board}.kicad_pcb"))
    data = json.loads(out.read_text())
    errors = [(k, v["type"], v["description"]) for k in
              ("violations", "unconnected_items", "schematic_parity")
              for v in data.get(k, []) if v["severity"] == "error"]
    assert errors == []


def symbols(board: str) -> list[dict]:
    tree = parse((PCB / board / f"{board}.kicad_sch").read_text(encoding="utf-8"))
    out = []
    for s in find_all(tree, "symbol"):
        props = {str(p[1]): str(p[2]) for p in find_all(s, "property")}
        out.append({"lib_id": str(find(s, "lib_id")[1]), "in_bom": find(s, "in_bom")[1] == "yes",
                    **props})
    return out


@pytest.mark.parametrize("board", BOARDS)
def test_every_footprint_assigned(board):
    syms = [s for s in symbols(board) if not s["Reference"].startswith("#")]
    assert syms
    missing = [s["Reference"] for s in syms if not s.get("Footprint")]
    assert missing == []


@pytest.mark.parametrize("board", BOARDS)
def test_bom_has_manufacturer_and_mpn(board, outdir):
    out = outdir / f"{board}-bom.csv"
    run("sch", "export", "bom", "-o", str(out), "--fields",
        "Reference,Value,Footprint,Manufacturer,MPN", "--group-by", "Value,Footprint,MPN",
        str(PCB / board / f"{board}.kicad_sch"))
    rows = list(csv.DictReader(out.open()))
    assert rows
    for r in rows:
        assert r["Manufacturer"].strip() and r["MPN"].strip(), r
    in_bom = {s["Reference"] for s in symbols(board) if s["in_bom"] and
              not s["Reference"].startswith("#")}
    listed = set()
    for r in rows:
        for ref in r["Reference"].replace(" ", "").split(","):
            m = re.fullmatch(r"([A-Z]+)(\d+)-[A-Z]*(\d+)", ref)
            if m:
                listed |= {f"{m.group(1)}{k}" for k in range(int(m.group(2)), int(m.group(3)) + 1)}
            else:
                listed.add(ref)
    assert in_bom <= listed, sorted(in_bom - listed)


@pytest.mark.parametrize("board", BOARDS)
def test_exports(board, outdir):
    pcb = str(PCB / board / f"{board}.kicad_pcb")
    g = outdir / f"{board}-gerbers"
    g.mkdir()
    run("pcb", "export", "gerbers", "--no-protel-ext", "-o", str(g) + "/", "--layers",
        "F.Cu,B.Cu,F.SilkS,F.Mask,B.Mask,Edge.Cuts", pcb)
    for layer in ("F_Cu", "B_Cu", "F_Silkscreen", "F_Mask", "B_Mask", "Edge_Cuts"):
        f = g / f"{board}-{layer}.gbr"
        assert f.is_file() and f.stat().st_size > 200, f
    run("pcb", "export", "drill", "--format", "excellon", "-o", str(g) + "/", pcb)
    drills = list(g.glob("*.drl"))
    assert drills and all(d.stat().st_size > 50 for d in drills)
    step = outdir / f"{board}.step"
    run("pcb", "export", "step", "--drill-origin", "--subst-models", "--force", "-o",
        str(step), pcb)
    assert step.is_file() and step.stat().st_size > 5000
    assert "ISO-10303-21" in step.read_text(errors="replace")[:100]


# --- pin map: firmware/src/pins.h against the readout netlist --------------------------

def firmware_pins() -> dict:
    text = (ROOT / "firmware" / "src" / "pins.h").read_text()
    macro = {m.group(1): m.group(2) for m in re.finditer(r"#define (FT_\w+) (.+)", text)}
    douts = [int(v) for v in re.findall(r"\d+", macro["FT_DOUT_ARDUINO_PINS"])]
    return {"SCK": int(macro["FT_SCK_ARDUINO_PIN"]), "RATE": int(macro["FT_RATE_ARDUINO_PIN"]),
            "DOUT": douts}


def arduino_name(pin: int) -> str:
    return f"A{pin - 14}" if pin >= 14 else f"D{pin}"


@pytest.fixture(scope="module")
def readout_netlist(outdir):
    out = outdir / "readout.net"
    run("sch", "export", "netlist", "--format", "kicadsexpr", "-o", str(out),
        str(PCB / "readout" / "readout.kicad_sch"))
    tree = parse(out.read_text())
    nets = {}
    for net in find_all(find(tree, "nets"), "net"):
        for node in find_all(net, "node"):
            nets[(str(find(node, "ref")[1]), str(find(node, "pin")[1]))] = str(find(net, "name")[1])
    return nets


def uno_pin_numbers(board: str = "readout") -> dict[str, str]:
    """Arduino pin name (D2, A0, ...) -> symbol pin number, from the embedded symbol."""
    tree = parse((PCB / board / f"{board}.kicad_sch").read_text())
    sym = next(s for s in find_all(find(tree, "lib_symbols"), "symbol")
               if s[1] == "MCU_Module:Arduino_UNO_R3")
    out = {}
    for sub in find_all(sym, "symbol"):
        for p in find_all(sub, "pin"):
            name = str(find(p, "name")[1]).split("/")[0].replace("SDA", "A4").replace("SCL", "A5")
            out.setdefault(name, str(find(p, "number")[1]))
    return out


def test_pin_map_equals_firmware(readout_netlist):
    fw = firmware_pins()
    assert fw["SCK"] == 12 and fw["RATE"] == 13 and len(fw["DOUT"]) == 16
    uno = uno_pin_numbers()
    nets = readout_netlist
    hx = sorted({ref for ref, pin in nets if ref.startswith("U") and (ref, "11") in nets
                 and (ref, "15") in nets})
    assert len(hx) == 4                       # the 4-channel shield: channels 0..3
    sck = nets[("A1", uno[arduino_name(fw["SCK"])])]
    rate_mcu = nets[("A1", uno[arduino_name(fw["RATE"])])]
    for ch, ref in enumerate(sorted(hx, key=lambda r: int(r[1:]))):
        assert nets[(ref, "12")] == nets[("A1", uno[arduino_name(fw["DOUT"][ch])])], ch
        assert nets[(ref, "11")] == sck
        rate = nets[(ref, "15")]
        # RATE of every chip reaches the D13 net through JP1 (pins 1-2), or GND / +5V
        jp = {pin: net for (r, pin), net in nets.items() if r == "JP1"}
        assert jp["1"] == rate and jp["2"] == rate_mcu
        assert jp["4"].lstrip("/") == "GND" and jp["6"].lstrip("/") == "+5V"
    # nothing else on the DOUT pins of the unused channels 4..15
    for ch in range(4, 16):
        net = nets.get(("A1", uno[arduino_name(fw["DOUT"][ch])]), "unconnected-")
        assert net.startswith("unconnected-"), (ch, net)


# --- fingertip board against [mount] ----------------------------------------------------

def board_tree(path: Path):
    return parse(path.read_text(encoding="utf-8"))


def mech(x: float, y: float) -> tuple[float, float]:
    return (x - geo.ORIGIN_X, geo.ORIGIN_Y - y)


def close(a, b, tol=0.05) -> bool:
    return math.dist(a, b) <= tol


def test_fingertip_outline_and_holes_match_mount():
    from fingertip.hardware.params import load
    m = load().mount
    tree = board_tree(PCB / "fingertip" / "fingertip.kicad_pcb")
    lines, arcs = [], []
    for it in find_all(tree, "gr_line") + find_all(tree, "gr_arc"):
        if str(find(it, "layer")[1]) != "Edge.Cuts":
            continue
        pts = {k[0]: mech(float(k[1]), float(k[2])) for k in it[1:]
               if isinstance(k, list) and k[0] in ("start", "mid", "end")}
        (arcs if it[0] == "gr_arc" else lines).append(pts)
    assert len(lines) == 3 and len(arcs) == 3
    r_in = m.base_side_mm / (2 * math.sqrt(3))
    for ln in lines:   # straight edges: inradius from the axis, normal at -90/30/150 deg
        (x0, y0), (x1, y1) = ln["start"], ln["end"]
        nx, ny = (y1 - y0), -(x1 - x0)
        n = math.hypot(nx, ny)
        dist = abs(x0 * nx + y0 * ny) / n
        assert abs(dist - r_in) < 0.05
        ang = math.degrees(math.atan2(-ny if x0 * nx + y0 * ny < 0 else ny,
                                      -nx if x0 * nx + y0 * ny < 0 else nx)) % 360
        assert min(abs(ang - a) for a in (270.0, 30.0, 150.0)) < 0.5
    rc = m.base_corner_radius_mm
    for a in arcs:     # corner radius: the three points lie on a circle of radius rc
        (ax, ay), (bx, by), (cx, cy) = a["start"], a["mid"], a["end"]
        d = 2 * (ax * (by - cy) + bx * (cy - ay) + cx * (ay - by))
        ux = ((ax**2 + ay**2) * (by - cy) + (bx**2 + by**2) * (cy - ay) +
              (cx**2 + cy**2) * (ay - by)) / d
        uy = ((ax**2 + ay**2) * (cx - bx) + (bx**2 + by**2) * (ax - cx) +
              (cx**2 + cy**2) * (bx - ax)) / d
        assert abs(math.hypot(ax - ux, ay - uy) - rc) < 0.05
        assert abs(math.hypot(ux, uy) - 2 * (r_in - rc)) < 0.05
    # side length from the straight edges + corners: sum of the tangents equals the side
    side = math.dist(*lines[0].values()) + 2 * rc * math.tan(math.radians(60))
    assert abs(side - m.base_side_mm) < 0.05
    holes = []
    for fp in find_all(tree, "footprint"):
        at = find(fp, "at")
        for pad in find_all(fp, "pad"):
            if pad[2] == "np_thru_hole":
                holes.append((mech(float(at[1]) + float(find(pad, "at")[1]),
                                   float(at[2]) + float(find(pad, "at")[2])),
                              float(find(pad, "drill")[1])))
    assert len(holes) == len(m.mount_holes_xy_mm())
    for hx, hy in m.mount_holes_xy_mm():
        match = [d for c, d in holes if close(c, (hx, hy))]
        assert match and abs(match[0] - m.mount_clearance_diameter_mm) < 0.05, (hx, hy)


def test_fingertip_wire_pads_next_to_wire_holes():
    from fingertip.hardware.params import load
    m = load().mount
    tree = board_tree(PCB / "fingertip" / "fingertip.kicad_pcb")
    pads = {}
    for fp in find_all(tree, "footprint"):
        props = {str(p[1]): str(p[2]) for p in find_all(fp, "property")}
        if props.get("Reference", "").startswith("TP"):
            at = find(fp, "at")
            net = find(find(fp, "pad"), "net")
            pads[props["Reference"]] = (mech(float(at[1]), float(at[2])), str(net[-1]))
    expected = geo.wire_pads(m)
    assert len(pads) == len(expected) == 9
    holes = m.wire_holes_xy_mm()
    for k, e in enumerate(expected, start=1):
        pos, net = pads[f"TP{k}"]
        assert close(pos, (e["x"], e["y"]), 0.01)
        assert net.lstrip("/") == e["net"]
        assert math.dist(pos, holes[e["hole"]]) <= geo.MAX_PAD_TO_HOLE
    # every wire of the toml's hole assignment has a pad: 4 gauges, their return, the piezo
    nets = {n.lstrip("/") for _, n in pads.values()}
    assert nets == {"G0", "G1", "G2", "G3", "GAUGE_COM", "PIEZO_P", "PIEZO_N"}


def test_fingertip_generated_files_up_to_date(tmp_path):
    kicad_cli()
    subprocess.run([SYS_PY, str(PCB / "tools" / "gen_fingertip.py"), "--out", str(tmp_path)],
                   check=True, capture_output=True, timeout=300)
    a = (PCB / "fingertip" / "fingertip.kicad_sch").read_text()
    b = (tmp_path / "fingertip.kicad_sch").read_text()
    assert a == b, "pcb/fingertip/fingertip.kicad_sch is stale: run `make pcb-gen`"

    def geometry(path):
        t = board_tree(path)
        fps = sorted((str(find(fp, "property")[2]), tuple(find(fp, "at")[1:3]))
                     for fp in find_all(t, "footprint"))
        edges = sorted(tuple(map(tuple, (k for k in it[1:] if isinstance(k, list)
                                         and k[0] in ("start", "mid", "end"))))
                       for it in find_all(t, "gr_line") + find_all(t, "gr_arc"))
        segs = sorted(tuple(map(tuple, (k for k in it[1:] if isinstance(k, list)
                                        and k[0] in ("start", "end", "layer"))))
                      for it in find_all(t, "segment"))
        return fps, edges, segs
    assert geometry(PCB / "fingertip" / "fingertip.kicad_pcb") == \
        geometry(tmp_path / "fingertip.kicad_pcb")
    for f in ("fingertip.pretty/WirePad_0.8mm.kicad_mod",
              "fingertip.pretty/MountingHole_M2_2.2mm_NPTH.kicad_mod", "fp-lib-table"):
        assert (PCB / "fingertip" / f).read_text() == (tmp_path / f).read_text(), f


def test_readout_generated_files_up_to_date(tmp_path):
    """The readout generator is deterministic (seeded item UUIDs, fixed net order, no
    retries; about 12 s): a fresh run must reproduce every committed file byte for byte."""
    kicad_cli()
    subprocess.run([SYS_PY, str(PCB / "tools" / "gen_readout.py"), "--out", str(tmp_path)],
                   check=True, capture_output=True, timeout=300)
    ours = PCB / "readout"
    files = sorted(str(f.relative_to(tmp_path)) for f in tmp_path.rglob("*") if f.is_file())
    committed = sorted(str(f.relative_to(ours)) for f in ours.rglob("*") if f.is_file()
                       and f.suffix not in (".kicad_prl", ".bak") and "backups" not in f.parts)
    assert files == committed
    for f in files:
        assert (ours / f).read_bytes() == (tmp_path / f).read_bytes(), \
            f"pcb/readout/{f} is stale: run `make pcb-gen`"


def test_readout_uno_headers_at_r3_positions():
    """Header pads of the shield = KiCad's stock Module:Arduino_UNO_R3 pads, mirrored in y
    (the stock footprint is drawn as seen from below, kicad-footprints#864), with power
    pin 1 at 27.94 mm from the USB-side edge and 2.54 mm from the power-side edge."""
    stock = parse(Path("/usr/share/kicad/footprints/Module.pretty/Arduino_UNO_R3.kicad_mod")
                  .read_text(encoding="utf-8"))
    ref = {str(p[1]): (float(find(p, "at")[1]), float(find(p, "at")[2]))
           for p in find_all(stock, "pad")}
    tree = board_tree(PCB / "readout" / "readout.kicad_pcb")
    xs, ys = [], []
    for it in find_all(tree, "gr_line"):
        if str(find(it, "layer")[1]) == "Edge.Cuts":
            for k in ("start", "end"):
                xs.append(float(find(it, k)[1]))
                ys.append(float(find(it, k)[2]))
    assert (max(xs) - min(xs), max(ys) - min(ys)) == pytest.approx((68.58, 53.34), abs=1e-3)
    a1 = next(fp for fp in find_all(tree, "footprint")
              if any(str(p[1]) == "Reference" and str(p[2]) == "A1"
                     for p in find_all(fp, "property")))
    ax, ay = float(find(a1, "at")[1]), float(find(a1, "at")[2])
    assert len(find(a1, "at")) == 3 or float(find(a1, "at")[3]) == 0.0
    pads = {str(p[1]): (ax + float(find(p, "at")[1]), ay + float(find(p, "at")[2]))
            for p in find_all(a1, "pad")}
    assert set(pads) == set(ref) and len(ref) == 32
    for num, (sx, sy) in ref.items():
        x, y = pads[num]
        assert x - min(xs) == pytest.approx(27.94 + sx, abs=0.01), num
        assert max(ys) - y == pytest.approx(2.54 + sy, abs=0.01), num
