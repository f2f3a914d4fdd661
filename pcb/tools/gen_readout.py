#!/usr/bin/python3
"""Generate pcb/readout/: the 4-channel Arduino Uno shield (one fingertip).

    /usr/bin/python3 pcb/tools/gen_readout.py [--out DIR]

Four HX711 (datasheet application circuit, one per gauge, quarter bridges), the RATE
jumper, the piezo preamp and the FFC connector; pin map = firmware/src/pins.h.
"""
from __future__ import annotations

import sys
from functools import partial
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import fingertip_geometry as geo  # noqa: E402
from gen_common import (finish_project, generator_main, netlist,  # noqa: E402
                        write_project_files)
from schematic import Part, Schematic, uid  # noqa: E402

NAME = "readout"
LIB = "readout"
SHIELD_FP = "Arduino_UNO_R3_Shield"
CHANNELS = 4
# Firmware pin map (firmware/src/pins.h): DOUT of channel n on D(2+n); SCK D12; RATE D13.
DOUT_PIN = {0: "D2", 1: "D3", 2: "D4", 3: "D5"}
# Arduino_UNO_R3 symbol pin numbers of the header pins used.
UNO_PIN = {"D2": "17", "D3": "18", "D4": "19", "D5": "20", "D12": "27", "D13": "28",
           "+5V": "5", "GND1": "6", "GND2": "7", "GND3": "29"}
UNO_PIN.update({f"D{k}": str(15 + k) for k in range(6, 12)})   # D6..D11 (hand board)
UNO_PIN.update({f"A{k}": str(9 + k) for k in range(6)})        # A0..A5
# Board frame: shield top-left corner at (100, 100), 68.58 x 53.34 mm (Uno R3 outline).
BX, BY, BW, BH = 100.0, 100.0, 68.58, 53.34

R0603 = "Resistor_SMD:R_0603_1608Metric"
C0603 = "Capacitor_SMD:C_0603_1608Metric"
C0805 = "Capacitor_SMD:C_0805_2012Metric"
C0402 = "Capacitor_SMD:C_0402_1005Metric"
YAGEO = "YAGEO"
SAMSUNG = "Samsung Electro-Mechanics"


def res(value: str, mpn: str, tol: str = "1%") -> dict:
    return {"Manufacturer": YAGEO, "MPN": mpn, "Tolerance": tol}


CAP = {
    "100n": (C0603, {"Manufacturer": SAMSUNG, "MPN": "CL10B104KB8NNNC"}),
    "1u": (C0603, {"Manufacturer": SAMSUNG, "MPN": "CL10A105KB8NNNC"}),
    "10u": (C0805, {"Manufacturer": SAMSUNG, "MPN": "CL21A106KAYNNNE"}),
    "33p": (C0603, {"Manufacturer": SAMSUNG, "MPN": "CL10C330JB8NNNC"}),
}
RES = {
    "20k": "RC0603FR-0720KL", "8k2": "RC0603FR-078K2L", "100k": "RC0603FR-07100KL",
    "1M": "RC0603FR-071ML", "191k": "RC0603FR-07191KL", "10k": "RC0603FR-0710KL",
    "1k": "RC0603FR-071KL", "100": "RC0603FR-07100RL",
}


def add_uno(sch: Schematic, pins: dict[str, str]) -> None:
    """The Uno R3 headers (A1) with pins = {"D2": net, ...}; GND pins on GND, the rest open."""
    uno: dict[str, str | None] = {str(k): None for k in range(1, 33)}
    for name, net in pins.items():
        uno[UNO_PIN[name]] = net
    for g in ("GND1", "GND2", "GND3"):
        uno[UNO_PIN[g]] = "GND"
    sch.add(Part("A1", "MCU_Module:Arduino_UNO_R3", "Arduino_UNO_R3", f"{LIB}:{SHIELD_FP}",
                 uno, at=(40.64, 80.0),
                 fields={"Manufacturer": "Adafruit Industries", "MPN": "85",
                         "Description": "Shield stacking headers for Arduino R3 (1x10, "
                                        "2x 1x8, 1x6)"}))
    sch.power_flag("GND", (20.32, 40.64))


def add_ffc(sch: Schematic, ref: str, net_of, at, descr: str) -> None:
    """One fingertip's FFC connector; net_of(fingertip signal) -> this board's net."""
    ffc: dict[str, str | None] = {str(k): net_of(sig) for k, sig in
                                  readout_ffc_pinout().items()}
    ffc["MP"] = "GND"
    sch.add(Part(ref, "Connector_Generic_MountingPin:Conn_01x08_MountingPin",
                 "FH12-8S-0.5SH(55)", geo.FFC_FOOTPRINT, ffc, at=at,
                 fields={"Manufacturer": "Hirose Electric", "MPN": "FH12-8S-0.5SH(55)",
                         "Description": descr}))


def add_rate_jumper(sch: Schematic, at) -> None:
    """RATE jumper JP1: 1-2 = D13 (firmware), 3-4 = GND (10 SPS), 5-6 = +5V (80 SPS)."""
    sch.add(Part("JP1", "Connector_Generic:Conn_02x03_Odd_Even", "RATE",
                 "Connector_PinHeader_2.54mm:PinHeader_2x03_P2.54mm_Vertical",
                 {"1": "RATE", "3": "RATE", "5": "RATE", "2": "RATE_D13", "4": "GND",
                  "6": "+5V"}, at=at,
                 fields={"Manufacturer": "Wurth Elektronik", "MPN": "61300621121",
                         "Description": "RATE select: one shunt (Wurth 60900213421) on 1-2 "
                                        "D13 / 3-4 10 SPS / 5-6 80 SPS"}))


def add_r(sch: Schematic, ref: str, val: str, a: str, b: str, at, tol: str = "1%",
          mpn: str | None = None) -> None:
    sch.add(Part(ref, "Device:R", val, R0603, {"1": a, "2": b}, at=at,
                 fields=res(val, mpn or RES[val], tol)))


def add_c(sch: Schematic, ref: str, val: str, a: str, b: str, at) -> None:
    fp, f = CAP[val]
    sch.add(Part(ref, "Device:C", val, fp, {"1": a, "2": b}, at=at, fields=dict(f)))


def add_channel(sch: Schematic, n: int, x0: float, y0: float, vsup: str = "+5V",
                dvdd: str = "+5V", dvdd_cap: bool = False) -> None:
    """One HX711 channel n (datasheet circuit, quarter-bridge completion) at schematic
    (x0, y0). vsup feeds the chip's regulator and the AVDD pass transistor (the excitation
    current), dvdd its digital side; the 4-channel shield has both on the Uno's +5V."""
    R = partial(add_r, sch)
    C = partial(add_c, sch)
    u = f"U{n + 1}"
    sch.add(Part(u, "Analog_ADC:HX711", "HX711", "Package_SO:SOIC-16_3.9x9.9mm_P1.27mm",
                 {"1": vsup, "2": f"BASE{n}", "3": f"AVDD{n}", "4": f"VFB{n}", "5": "GND",
                  "6": f"VBG{n}", "7": f"REF{n}", "8": f"G{n}", "9": "GND", "10": "GND",
                  "11": "SCK", "12": f"DOUT{n}", "13": None, "14": "GND", "15": "RATE",
                  "16": dvdd}, at=(x0, y0),
                 fields={"Manufacturer": "Avia Semiconductor", "MPN": "HX711",
                         "Description": f"24-bit ADC, channel {n} (gauge {n % 4}), XI to "
                                        "GND: internal oscillator"}))
    k = 10 * (n + 1)
    sch.add(Part(f"Q{n + 1}", "Transistor_BJT:SS8550", "SS8550", "Package_TO_SOT_SMD:SOT-23",
                 {"1": f"BASE{n}", "2": vsup, "3": f"AVDD{n}"}, at=(x0 - 30, y0 - 20),
                 fields={"Manufacturer": "Jiangsu Changjiang Electronics (JCET)",
                         "MPN": "SS8550", "Description": "AVDD pass transistor (datasheet: "
                                                         "S8550)"}))
    R(f"R{k + 1}", "20k", f"AVDD{n}", f"VFB{n}", (x0 - 40, y0))
    R(f"R{k + 2}", "8k2", f"VFB{n}", "GND", (x0 - 40, y0 + 12))
    R(f"R{k + 3}", "120", f"AVDD{n}", f"G{n}", (x0 + 35, y0 - 15), "0.1%",
      "RT0603BRD07120RL")
    R(f"R{k + 4}", "120", f"AVDD{n}", f"REF{n}", (x0 + 45, y0 - 15), "0.1%",
      "RT0603BRD07120RL")
    R(f"R{k + 5}", "120", f"REF{n}", "GND", (x0 + 45, y0 + 0), "0.1%", "RT0603BRD07120RL")
    C(f"C{k + 1}", "10u", f"AVDD{n}", "GND", (x0 - 50, y0 - 5))
    C(f"C{k + 2}", "100n", f"AVDD{n}", "GND", (x0 - 55, y0 - 5))
    C(f"C{k + 3}", "100n", f"VBG{n}", "GND", (x0 - 50, y0 + 15))
    C(f"C{k + 4}", "100n", vsup, "GND", (x0 + 20, y0 - 30))
    if dvdd_cap:
        # 0402 (not 0603 like the rest): it sits in the gap right of pin 16, between the
        # chip and the next channel's regulator column, where the routes are dense
        sch.add(Part(f"C{k + 5}", "Device:C", "100n", C0402, {"1": dvdd, "2": "GND"},
                     at=(x0 + 30, y0 - 30),
                     fields={"Manufacturer": SAMSUNG, "MPN": "CL05B104KO5NNNC",
                             "Description": f"DVDD decoupling of U{n + 1} (datasheet)"}))
    sch.power_flag(f"AVDD{n}", (x0 - 60, y0 - 20))


def add_preamp(sch: Schematic, ref, net, dx: float = 0.0, dy: float = 0.0) -> None:
    """The piezo preamp (MCP6002: A = gain stage, B = mid-rail buffer) and its 3.5 mm jack.
    ref / net map the 4-channel shield's references and net names to this copy's."""
    def R(r, val, a, b, at):
        add_r(sch, ref(r), val, net(a), net(b), (at[0] + dx, at[1] + dy))

    def C(r, val, a, b, at):
        add_c(sch, ref(r), val, net(a), net(b), (at[0] + dx, at[1] + dy))
    sch.add(Part(ref("U5"), "Amplifier_Operational:MCP6002-xSN", "MCP6002",
                 "Package_SO:SOIC-8_3.9x4.9mm_P1.27mm",
                 {p: net(v) for p, v in (("3", "PZ_IN"), ("2", "FB"), ("1", "AMP_OUT"),
                                         ("5", "VMID_DIV"), ("6", "VMID"), ("7", "VMID"),
                                         ("8", "+5V"), ("4", "GND"))},
                 at=(130.0 + dx, 220.0 + dy),
                 unit_at={1: (130.0 + dx, 220.0 + dy), 2: (130.0 + dx, 250.0 + dy),
                          3: (160.0 + dx, 250.0 + dy)},
                 fields={"Manufacturer": "Microchip Technology", "MPN": "MCP6002T-I/SN"}))
    R("R2", "1k", "PIEZO_P", "PZ_IN", (100.0, 215.0))
    R("R3", "1M", "PZ_IN", "VMID", (110.0, 230.0))
    R("R4", "191k", "AMP_OUT", "FB", (150.0, 205.0))
    C("C2", "33p", "AMP_OUT", "FB", (160.0, 205.0))
    R("R5", "10k", "FB", "RG_AC", (120.0, 235.0))
    C("C3", "1u", "RG_AC", "GND", (120.0, 245.0))
    R("R6", "100k", "+5V", "VMID_DIV", (100.0, 245.0))
    R("R7", "100k", "VMID_DIV", "GND", (100.0, 260.0))
    C("C4", "10u", "VMID_DIV", "GND", (90.0, 260.0))
    C("C5", "10u", "AMP_OUT", "OUT_AC", (170.0, 225.0))
    R("R8", "100", "OUT_AC", "AUDIO", (180.0, 225.0))
    R("R9", "100k", "AUDIO", "GND", (190.0, 235.0))
    C("C6", "100n", "+5V", "GND", (180.0, 250.0))
    sch.add(Part(ref("J3"), "Connector_Audio:AudioJack3", "SJ1-3523N",
                 "Connector_Audio:Jack_3.5mm_CUI_SJ1-3523N_Horizontal",
                 {"T": net("AUDIO"), "R": None, "S": "GND"}, at=(205.0 + dx, 225.0 + dy),
                 fields={"Manufacturer": "CUI Devices", "MPN": "SJ1-3523N",
                         "Description": "to the USB sound card's mic/line input (tip)"}))


def readout_ffc_pinout() -> dict[int, str]:
    """Readout connector pin -> fingertip signal. Same-side (type A) FFC, both connectors
    top-contact, facing each other: fingertip pin n lands on readout pin 9 - n."""
    n = len(geo.FFC_PINOUT)
    return {n + 1 - k: sig for k, sig in geo.FFC_PINOUT.items()}


def ffc_net(sig: str) -> str:
    # gauge returns, piezo return and shield all end on the readout's ground
    return {"GAUGE_COM": "GND", "PIEZO_N": "GND", "GND": "GND"}.get(sig, sig)


class Layout:
    """Schematic position and board position of every part."""

    def __init__(self):
        self.board: dict[str, tuple[float, float, float]] = {}


def build_schematic(lay: Layout) -> Schematic:
    sch = Schematic(NAME, "Readout shield: 4 x HX711 quarter bridges, piezo preamp", "A2",
                    comments=(
                        "Generated by pcb/tools/gen_readout.py: do not edit",
                        "Pin map = firmware/src/pins.h: DOUT0..3 = D2..D5, SCK = D12, "
                        "RATE = D13 (via JP1)",
                        "Quarter bridge per gauge: 3 x 120R 0.1% completion, excitation AVDD "
                        "4.3 V",
                        "Preamp: 1M bias to mid-rail (80 Hz with 2 nF), gain 1+191k/10k = 20.1"))
    R = partial(add_r, sch)
    C = partial(add_c, sch)
    add_uno(sch, {**{DOUT_PIN[n]: f"DOUT{n}" for n in range(CHANNELS)},
                  "D12": "SCK", "D13": "RATE_D13", "+5V": "+5V"})
    add_ffc(sch, "J1", ffc_net, (40.64, 160.0), "FFC from the fingertip, 8 x 0.5 mm")
    add_rate_jumper(sch, (40.64, 200.0))
    R("R1", "100k", "RATE", "GND", (60.96, 200.0))
    C("C1", "10u", "+5V", "GND", (60.96, 220.0))
    for n in range(CHANNELS):
        add_channel(sch, n, 110.0 + 75.0 * (n % 2), 40.0 + 85.0 * (n // 2))
    add_preamp(sch, lambda r: r, lambda n: n)
    sch.note("Bridge (each channel n): gauge n (on the fingertip) from G n to GAUGE_COM (= GND)\n"
             "R n3 from AVDD n to G n; R n4 / R n5 form the reference half (AVDD n / 2).\n"
             "INA+ = G n, INA- = REF n: tension (R up) reads positive. Gain 128, channel A.\n"
             "AVDD n = 1.25 V x (20k + 8k2) / 8k2 = 4.30 V (Q n + R n1 / R n2).\n"
             "FFC: same-side (type A) cable: fingertip pin n -> readout pin 9-n.\n"
             "16 channels: four shields? No: one Uno; see pcb/README.md (variant).",
             (20.0, 250.0))
    return sch


def shield_footprint(lib: Path) -> None:
    """The Uno R3 header pads (top view, digital row on top), numbered as the symbol."""
    lib.mkdir(parents=True, exist_ok=True)
    pads = []
    # power header 1..8, analog 9..14: bottom row; digital 15..32: top row (see layout()).
    for num, (x, y) in uno_pads(0.0, 0.0).items():
        shape = "rect" if num == 1 else "circle"
        pads.append(f'\t(pad "{num}" thru_hole {shape} (at {x:.2f} {y:.2f}) (size 1.7 1.7) '
                    f'(drill 1.0) (layers "*.Cu" "*.Mask"))')
    text = (f"(footprint \"{SHIELD_FP}\"\n\t(version 20241229)\n"
            "\t(generator \"fingertip_pcbgen\")\n"
            "\t(layer \"F.Cu\")\n\t(descr \"Arduino Uno R3 shield headers (pads only; origin "
            "= power header pin 1)\")\n\t(attr through_hole)\n"
            "\t(property \"Reference\" \"REF**\" (at 0 2.5 0) (layer \"F.SilkS\") (hide yes)\n"
            "\t\t(effects (font (size 1 1) (thickness 0.15))))\n"
            f"\t(property \"Value\" \"{SHIELD_FP}\" (at 0 4 0) (layer \"F.Fab\")\n"
            "\t\t(effects (font (size 1 1) (thickness 0.15))))\n")
    for x0, y0, x1, y1 in ((-1.3, -1.3, 19.1, 1.3), (21.5, -1.3, 36.9, 1.3),
                           (-10.5, -49.6, 19.1, -46.9), (21.5, -49.6, 36.9, -46.9)):
        text += (f"\t(fp_rect (start {x0} {y0}) (end {x1} {y1}) (stroke (width 0.05) "
                 f"(type solid)) (fill no) (layer \"F.CrtYd\"))\n")
    text += "\n".join(pads) + "\n)\n"
    (lib / f"{SHIELD_FP}.kicad_mod").write_text(text, encoding="utf-8")


def uno_pads(ox: float, oy: float) -> dict[int, tuple[float, float]]:
    """Pad centres relative to power-header pin 1 (KiCad frame, y down)."""
    p = {}
    for k in range(8):                     # NC IOREF RESET 3V3 5V GND GND VIN
        p[1 + k] = (ox + 2.54 * k, oy)
    for k in range(6):                     # A0..A5
        p[9 + k] = (ox + 22.86 + 2.54 * k, oy)
    for k in range(8):                     # D0..D7, right to left
        p[15 + k] = (ox + 35.56 - 2.54 * k, oy - 48.26)
    for k in range(10):                    # D8..D13 GND AREF SDA SCL
        p[23 + k] = (ox + 13.72 - 2.54 * k, oy - 48.26)
    return p


# x of the DVDD capacitor's centre from the HX711's centre (0402 pads at +-0.48): its
# courtyard clears the SOIC's (x + 3.7) and the next channel's SOT-23 (x + 5.87). Found by
# trying on the hand shield: at 4.6 the courtyards overlap; at 4.75 a +5V track on B.Cu cut
# off one GND pour fragment (1 unconnected item); at 4.9 a DOUT line did not route.
DVDD_CAP_DX = 4.7


def place_channel(pl: dict, n: int, cx: float, cy: float, dvdd_cap: bool = False) -> None:
    """Footprints of channel n around its HX711 at (cx, cy): the regulator parts in a column
    on the left, the decoupling above, the bridge completion below."""
    k = 10 * (n + 1)
    pl[f"U{n + 1}"] = (cx, cy, 0.0)
    lx = cx - 6.8
    pl[f"Q{n + 1}"] = (lx, cy - 4.6, 0.0)
    for i, ref in enumerate(column_refs(n)):
        pl[ref] = (lx, cy - 1.9 + 1.8 * i, 0.0)
    pl[f"C{k + 1}"] = (cx - 2.3, cy - 7.2, 0.0)
    pl[f"C{k + 4}"] = (cx + 1.9, cy - 7.2, 0.0)
    if dvdd_cap:
        # in line with pin 16 (DVDD, pad centre at x + 2.475), its DVDD pad 0.39 mm from the
        # pin: a stub, not a route, and the GND pad gets its own via to the pour
        pl[f"C{k + 5}"] = (cx + DVDD_CAP_DX, cy - 4.445, 0.0)
    pl[f"R{k + 3}"] = (cx - 3.0, cy + 8.6, 0.0)
    pl[f"R{k + 4}"] = (cx + 0.4, cy + 8.6, 0.0)
    pl[f"R{k + 5}"] = (cx + 3.8, cy + 8.6, 0.0)


def column_refs(n: int) -> tuple[str, ...]:
    k = 10 * (n + 1)
    return (f"C{k + 2}", f"R{k + 1}", f"R{k + 2}", f"C{k + 3}")


def small_refs_left(bb, pl: dict, channels: int) -> None:
    """The stacked column left of each HX711: references left of the parts (not on pads)."""
    import pcbnew
    for n in range(channels):
        for ref in column_refs(n):
            x, y, _ = pl[ref]
            t = bb.fps[ref].Reference()
            t.SetPosition(pcbnew.VECTOR2I(pcbnew.FromMM(x - 2.5), pcbnew.FromMM(y)))
            t.SetTextSize(pcbnew.VECTOR2I(pcbnew.FromMM(0.8), pcbnew.FromMM(0.8)))
            t.SetTextThickness(pcbnew.FromMM(0.12))


def placements() -> dict[str, tuple[float, float, float]]:
    """(x, y, rotation) of every footprint on the shield."""
    pl: dict[str, tuple[float, float, float]] = {}
    pl["A1"] = (BX + 27.94, BY + BH - 2.54, 0.0)
    pl["J1"] = (BX + 3.0, BY + 24.05, 270.0)
    # JP1 (through-hole) above the Uno's DC jack: the jack body (about 12.5 x 9 mm from the
    # USB-side edge, 3.2..12.3 mm from the power-side edge, 11 mm tall) sits right under the
    # shield, so no pins below y = BY + 40; the USB-B (9.2..20.9 mm from the top edge,
    # 10 mm deep) only has SMD parts and tented vias above it
    pl["JP1"] = (BX + 2.6, BY + 32.5, 0.0)
    pl["R1"] = (BX + 9.0, BY + 35.0, 90.0)
    pl["C1"] = (BX + 24.0, BY + 45.0, 0.0)
    pitch = 14.6
    for n in range(CHANNELS):
        place_channel(pl, n, BX + 17.0 + pitch * n, BY + 16.5)
    # preamp row
    py = BY + 36.0
    pl["U5"] = (BX + 36.0, py, 0.0)
    row = ["R2", "R3", "R6", "R7", "C4"]
    for i, r in enumerate(row):
        pl[r] = (BX + 16.0 + 3.3 * i, py + 3.0, 90.0)
    row2 = ["R4", "C2", "R5", "C3"]
    for i, r in enumerate(row2):
        pl[r] = (BX + 42.5 + 3.3 * i, py - 1.5, 90.0)
    row3 = ["C5", "R8", "R9", "C6"]
    for i, r in enumerate(row3):
        pl[r] = (BX + 42.5 + 3.3 * i, py + 4.5, 90.0)
    pl["J3"] = (BX + BW - 6.6, BY + 36.5, 90.0)
    return pl


def build(out: Path) -> list[str]:
    base = ["SCK", "RATE", "RATE_D13"]
    base += [f"DOUT{n}" for n in range(CHANNELS)]
    for n in range(CHANNELS):
        base += [f"BASE{n}", f"VFB{n}", f"VBG{n}", f"G{n}", f"REF{n}", f"AVDD{n}"]
    base += ["PIEZO_P", "PZ_IN", "FB", "RG_AC", "VMID", "VMID_DIV", "AMP_OUT", "OUT_AC",
             "AUDIO", "+5V", "GND"]
    texts = [("fingertip readout (4 ch)", BX + 44, BY + 44.6),
             ("D2-D5 DOUT  D12 SCK  D13 RATE", BX + 44, BY + 46.0),
             ("JP1 RATE: 1-2 D13", BX + 7.3, BY + 39.8),
             ("3-4 10SPS  5-6 80SPS", BX + 8.4, BY + 41.2)]
    return generate_shield(out, NAME, build_schematic(Layout()), base,
                           (BW, BH), placements(), CHANNELS, ["J3"], texts)


def generate_shield(out: Path, name: str, sch: Schematic, base: list[str],
                    size: tuple[float, float], pl: dict, channels: int, jacks: list[str],
                    texts: list[tuple[str, float, float]], descr: str = "readout",
                    stitch_pitch: float = 4.0, join: bool = False) -> list[str]:
    """Write a shield project: footprints, schematic, routed board; returns what failed.
    base: routing order of the nets (the rest after them, sorted)."""
    out.mkdir(parents=True, exist_ok=True)
    # start from nothing: pcbnew reads an existing project file, and the output (item UUIDs,
    # their order in the file) would then depend on the previous run
    for ext in ("kicad_pcb", "kicad_pro", "kicad_prl"):
        (out / f"{name}.{ext}").unlink(missing_ok=True)
    shield_footprint(out / f"{LIB}.pretty")
    write_project_files(out, name, LIB, f"{descr} shield footprints (generated)")
    sch_path = out / f"{name}.kicad_sch"
    sch.write(sch_path)
    pin_nets = netlist(sch_path)
    names = set(pin_nets.values())
    full = {n.lstrip("/"): n for n in names}
    order = [full[b] for b in base if b in full]
    missing = sorted(set(full) - set(base))
    order += [full[m] for m in missing]
    failed = shield_board(out, name, sch, pin_nets, order, size, pl, channels, jacks, texts,
                          stitch_pitch, join)
    finish_project(out / f"{name}.kicad_pro", uid(name, "root"))
    (out / f"{name}.kicad_prl").unlink(missing_ok=True)
    return failed


def shield_board(out: Path, name: str, sch: Schematic, pin_nets, order, size, pl, channels,
                 jacks, texts, stitch_pitch: float = 4.0, join: bool = False) -> list[str]:
    """Place, route (GND as planes), stitch, pour and save; Uno outline at (BX, BY)."""
    import pcbnew
    from board import BoardBuilder, Rules, join_fragments, polygon_inside, stitch

    pcbnew.KIID.SeedGenerator(1)   # same item UUIDs every run: byte-identical output
    rules = Rules(track=0.2, clearance=0.15, via=0.6, drill=0.3, edge=0.3, hole_clearance=0.25,
                  grid=0.1)
    bb = BoardBuilder(str(out / f"{name}.kicad_pcb"), rules)
    w, h = size
    corners = [(BX, BY), (BX + w, BY), (BX + w, BY + h), (BX, BY + h)]
    for a, b in zip(corners, corners[1:] + corners[:1], strict=False):
        bb.edge_line(a, b)
    bb.set_aux_origin(BX, BY + h)
    for p in sch.parts:
        x, y, rot = pl[p.ref]
        libdir = str(out / f"{LIB}.pretty") if p.footprint.startswith(LIB + ":") else None
        bb.place(p.ref, p.footprint, x, y, rot, p.value, uid(f"{name}/{p.ref}/1"),
                 libdir=libdir, show_ref=p.ref != "A1")   # A1: the headers, no silk label
    small_refs_left(bb, pl, channels)
    # the jack's library footprint says "exclude from BOM"; it is a BOM part here
    for j in jacks:
        fp = bb.fps[j]
        fp.SetAttributes(fp.GetAttributes() & ~pcbnew.FP_EXCLUDE_FROM_BOM)
    ds = bb.board.GetDesignSettings()
    ds.m_TentViasFront = ds.m_TentViasBack = True   # no bare vias over the Uno's USB shell
    bb.assign(pin_nets)
    inside = polygon_inside(corners)
    gnd = next(n for n in bb.nets if n.lstrip("/") == "GND")
    failed = bb.route_all(order, inside, (BX - 0.5, BY - 0.5, BX + w + 0.5, BY + h + 0.5),
                          plane_nets=(gnd,))
    stitch(bb, gnd, stitch_pitch)
    inset = [(BX + 0.4, BY + 0.4), (BX + w - 0.4, BY + 0.4), (BX + w - 0.4, BY + h - 0.4),
             (BX + 0.4, BY + h - 0.4)]
    bb.zone(gnd, pcbnew.B_Cu, inset)
    bb.zone(gnd, pcbnew.F_Cu, inset)
    for txt, x, y in texts:
        bb.text(txt, x, y, size=0.8)
    if join:
        pcbnew.ZONE_FILLER(bb.board).Fill(bb.board.Zones())
        join_fragments(bb.board, gnd, rules)
    unconnected = bb.save()
    if unconnected:
        failed.append(f"{unconnected} unconnected item(s) after the zone fill")
    return failed


def main() -> int:
    return generator_main(__doc__, "readout", HERE.parent / NAME, build)


if __name__ == "__main__":
    raise SystemExit(main())
