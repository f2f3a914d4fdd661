"""The 16-channel hand shield (pcb/hand): pin map against firmware/src/pins.h, each FFC against
the fingertip board's pin-out, supplies, the SCK edge, the schematic against its generator.
ERC, DRC with parity, BOM fields and the exports are in test_boards.py (BOARDS)."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tests.pcb.test_boards import (PCB, ROOT, SYS_PY, arduino_name, firmware_pins, kicad_cli,
                                   run, uno_pin_numbers)

sys.path.insert(0, str(PCB / "tools"))
import fingertip_geometry as geo  # noqa: E402
from sexpr import find, find_all, parse  # noqa: E402

HAND = PCB / "hand"


@pytest.fixture(scope="module")
def nets(tmp_path_factory) -> dict[tuple[str, str], str]:
    out = tmp_path_factory.mktemp("hand") / "hand.net"
    run("sch", "export", "netlist", "--format", "kicadsexpr", "-o", str(out),
        str(HAND / "hand.kicad_sch"))
    tree = parse(out.read_text())
    res = {}
    for net in find_all(find(tree, "nets"), "net"):
        for node in find_all(net, "node"):
            res[(str(find(node, "ref")[1]), str(find(node, "pin")[1]))] = \
                str(find(net, "name")[1]).lstrip("/")
    return res


def uno_pins() -> dict[str, str]:
    return uno_pin_numbers("hand")


def hx711s(nets) -> list[str]:
    """HX711 references (the parts with an SCK pin 11 and a RATE pin 15), by channel."""
    refs = {r for r, p in nets if r.startswith("U") and (r, "11") in nets and (r, "15") in nets}
    return sorted(refs, key=lambda r: int(r[1:]))


def test_pin_map_equals_the_16_channel_firmware(nets):
    fw = firmware_pins()
    uno = uno_pins()
    chips = hx711s(nets)
    assert len(chips) == 16 == len(fw["DOUT"])
    sck = nets[("A1", uno[arduino_name(fw["SCK"])])]
    rate_mcu = nets[("A1", uno[arduino_name(fw["RATE"])])]
    jp = {pin: net for (r, pin), net in nets.items() if r == "JP1"}
    for ch, ref in enumerate(chips):
        dout = nets[(ref, "12")]
        assert dout == nets[("A1", uno[arduino_name(fw["DOUT"][ch])])], ch
        assert nets[(ref, "11")] == sck == "SCK"
        assert nets[(ref, "15")] == jp["1"]
    assert jp["2"] == rate_mcu and jp["4"] == "GND" and jp["6"] == "+5V"
    # each DOUT net is one chip's and its header pin's: no two channels share a line
    douts = [nets[(ref, "12")] for ref in chips]
    assert len(set(douts)) == 16
    for d in douts:
        assert sorted(r for (r, p), n in nets.items() if n == d) == sorted(
            ["A1", next(r for r in chips if nets[(r, "12")] == d)])


def test_each_ffc_matches_the_fingertip_pinout(nets):
    """Finger f's connector J(f+1): fingertip pin n lands on pin 9-n (type A cable, both
    connectors top contact); gauge k goes to channel 4f+k's bridge (INA+ and its completion
    resistor), the piezo to preamp f's input, returns and shield to GND."""
    chips = hx711s(nets)
    for f in range(4):
        j = f"J{f + 1}"
        assert (j, "MP") in nets and nets[(j, "MP")] == "GND"
        for pin, sig in geo.FFC_PINOUT.items():
            net = nets[(j, str(len(geo.FFC_PINOUT) + 1 - pin))]
            if sig in ("GAUGE_COM", "GND", "PIEZO_N"):
                assert net == "GND", (f, sig)
            elif sig.startswith("G"):
                ch = 4 * f + int(sig[1:])
                assert net == nets[(chips[ch], "8")] == f"G{ch}", (f, sig)
                # the quarter-bridge completion resistor from AVDD of the same channel
                avdd = nets[(chips[ch], "3")]
                assert any(nets.get((r, "1")) == avdd and nets.get((r, "2")) == net
                           for r, _ in nets if r.startswith("R")), (f, sig)
            else:
                assert sig == "PIEZO_P" and net == f"PIEZO_P{f}"
                users = sorted(r for (r, p), n in nets.items() if n == net)
                assert users == sorted([j, f"R{200 + 20 * f + 2}"]), users
    # the same connector part and footprint as the readout shield
    sch = (HAND / "hand.kicad_sch").read_text()
    assert sch.count(f'"Footprint" "{geo.FFC_FOOTPRINT}"') == 4


def test_supplies_bridges_on_the_external_input(nets):
    chips = hx711s(nets)
    for ch, ref in enumerate(chips):
        assert nets[(ref, "1")] == "VBR", ch          # VSUP: the external 5 V
        assert nets[(ref, "16")] == "+5V", ch         # DVDD: the Uno's logic supply
        assert nets[(f"Q{ch + 1}", "2")] == "VBR"     # AVDD pass transistor's emitter
    # J9 -> F1 (PTC) -> TVS to GND -> P-FET drain; source = VBR, gate to GND
    assert nets[("J9", "1")] == nets[("F1", "1")]
    assert nets[("F1", "2")] == nets[("D1", "1")] == nets[("Q17", "3")]
    assert nets[("D1", "2")] == "GND" and nets[("Q17", "2")] == "VBR"
    assert nets[("R2", "1")] == nets[("Q17", "1")] and nets[("R2", "2")] == "GND"
    # nothing ties VBR to the Uno's +5V (the two supplies are never in parallel)
    assert not any(n == "VBR" for (r, p), n in nets.items() if r == "A1")


def test_sck_edge_against_hx711_timing():
    sys.path.insert(0, str(PCB / "tools"))
    from sck_edge import T_SCK_MIN_US, sck_edge

    e = sck_edge(HAND / "hand.kicad_pcb")
    assert e.track_mm > 50 and e.vias >= 0
    assert e.lumped
    # at least 4 edges inside the HX711's minimum SCK-high time: no buffer needed
    assert e.rise_ns * 4 < T_SCK_MIN_US * 1e3, e


def test_schematic_up_to_date(tmp_path):
    """The schematic equals a fresh one from the generator (the board follows it: DRC's
    schematic parity in test_boards.py)."""
    kicad_cli()
    out = tmp_path / "hand.kicad_sch"
    code = (f"import sys; sys.path.insert(0, {str(PCB / 'tools')!r}); import gen_hand; "
            f"gen_hand.build_schematic().write(__import__('pathlib').Path({str(out)!r}))")
    subprocess.run([SYS_PY, "-c", code], check=True, capture_output=True, timeout=300)
    assert out.read_text() == (HAND / "hand.kicad_sch").read_text(), \
        "pcb/hand/hand.kicad_sch is stale: run `make pcb-gen`"
    assert ROOT.is_dir()


def test_uno_headers_at_r3_positions():
    """Same header footprint and place as the readout shield (checked against KiCad's stock
    Arduino footprint there); the hand board is larger, the Uno outline its top-left."""
    def a1(board: Path):
        tree = parse(board.read_text(encoding="utf-8"))
        fp = next(fp for fp in find_all(tree, "footprint")
                  if any(str(p[1]) == "Reference" and str(p[2]) == "A1"
                         for p in find_all(fp, "property")))
        edges = [float(find(it, k)[i]) for it in find_all(tree, "gr_line")
                 if str(find(it, "layer")[1]) == "Edge.Cuts" for k in ("start", "end")
                 for i in (1, 2)]
        at = find(fp, "at")
        return (float(at[1]) - min(edges[0::2]), float(at[2]) - min(edges[1::2])), \
            sorted((str(p[1]), tuple(find(p, "at")[1:3])) for p in find_all(fp, "pad"))
    assert a1(HAND / "hand.kicad_pcb") == a1(PCB / "readout" / "readout.kicad_pcb")


def test_each_hx711_has_its_own_dvdd_capacitor_next_to_pin_16(nets):
    """The datasheet's reference design decouples DVDD (pin 16) at each chip: a 100 nF from
    +5V to GND per HX711, placed with its +5V pad within 2 mm of the chip's pin 16 (a stub,
    not a route across the board), its own via to the GND pour."""
    tree = parse((HAND / "hand.kicad_pcb").read_text(encoding="utf-8"))

    def ref_of(fp) -> str:
        return next(str(p[2]) for p in find_all(fp, "property") if str(p[1]) == "Reference")
    fps = {ref_of(fp): fp for fp in find_all(tree, "footprint")}

    def pad_xy(ref: str, num: str) -> tuple[float, float]:
        import math
        fp = fps[ref]
        at = find(fp, "at")
        x0, y0 = float(at[1]), float(at[2])
        rot = math.radians(float(at[3]) if len(at) > 3 else 0.0)
        pad = next(p for p in find_all(fp, "pad") if str(p[1]) == num)
        px, py = float(find(pad, "at")[1]), float(find(pad, "at")[2])
        # KiCad rotates counter-clockwise on screen (y down)
        return (x0 + px * math.cos(rot) + py * math.sin(rot),
                y0 - px * math.sin(rot) + py * math.cos(rot))
    chips = hx711s(nets)
    assert len(chips) == 16
    for ref in chips:
        caps = [r for (r, p), n in nets.items() if r.startswith("C") and n == "+5V"
                and nets.get((r, "2" if p == "1" else "1")) == "GND"]
        near = []
        for c in caps:
            plus = "1" if nets[(c, "1")] == "+5V" else "2"
            (ax, ay), (bx, by) = pad_xy(c, plus), pad_xy(ref, "16")
            if ((ax - bx) ** 2 + (ay - by) ** 2) ** 0.5 < 2.0:
                near.append(c)
        assert len(near) == 1, (ref, near)
