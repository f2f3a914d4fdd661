"""The fingertip PCB (pcb/fingertip) fits the base: outline, M2 holes, parts in the pocket."""
from __future__ import annotations

import math
from pathlib import Path

import pytest

from fingertip_cad.checks import pcb_fit_problems
from fingertip_cad.kicad import read_board

ROOT = Path(__file__).resolve().parents[2]
BOARD = ROOT / "pcb" / "fingertip" / "fingertip.kicad_pcb"


def test_the_fingertip_pcb_fits_the_base(shipped):
    if not BOARD.is_file():
        pytest.fail(f"{BOARD.relative_to(ROOT)} is missing: the fingertip PCB must exist for "
                    "the base to be checked against it (generated in pcb/)")
    board = read_board(BOARD)
    assert pcb_fit_problems(board, shipped.dims, shipped.parts.base) == []


def test_the_pocket_outline_function_matches_the_base(cad):
    """``Dims.pocket_contains`` (pure Python, for pcb/ to use) says the same as the solid."""
    import numpy as np

    from fingertip_cad.checks import inside

    d = cad.dims
    z = d.p.mount.pocket_depth_mm / 2
    rng = np.random.default_rng(0)
    pts = rng.uniform(-d.base_inradius * 2, d.base_inradius * 2, size=(400, 2))
    for x, y in pts:
        if d.base_signed_distance((x, y)) > 0:
            continue                                   # beyond the base: no material
        pilot = d.p.mount.mount_pilot_diameter_mm / 2 + 0.02
        if any(math.dist((x, y), h) < pilot for h in d.p.mount.mount_holes_xy_mm()):
            continue                                   # in an M2 pilot hole
        margin = 0.02
        if any(d.pocket_contains((x + dx, y + dy)) != d.pocket_contains((x, y))
               for dx, dy in ((margin, 0), (-margin, 0), (0, margin), (0, -margin))):
            continue                                   # on the pocket's edge
        assert d.pocket_contains((x, y)) == (not inside(cad.parts.base, (x, y, z))), (x, y)


def contract_board(d, shift_hole: float = 0.0, part_xy=(0.0, -3.0), part_w: float = 6.0) -> str:
    """A .kicad_pcb drawn from the [mount] contract alone (as pcb/ must), with one SMD part."""
    m = d.p.mount
    ox, oy = 100.0, 100.0

    def k(x: float, y: float) -> str:
        return f"{ox + x:.6f} {oy - y:.6f}"

    rc = m.base_corner_radius_mm
    a = d.base_inradius - rc
    verts = {t: (2 * a * math.cos(math.radians(t)), 2 * a * math.sin(math.radians(t)))
             for t in (90, 210, 330)}

    def off(v, ang):
        return (v[0] + rc * math.cos(math.radians(ang)), v[1] + rc * math.sin(math.radians(ang)))

    items = []
    for (t0, t1), n in (((210, 330), 270), ((330, 90), 30), ((90, 210), 150)):
        s, e = off(verts[t0], n), off(verts[t1], n)
        items.append(f'(gr_line (start {k(*s)}) (end {k(*e)}) (layer "Edge.Cuts"))')
    for t in (90, 210, 330):
        s, mid, e = off(verts[t], t - 60), off(verts[t], t), off(verts[t], t + 60)
        items.append(f'(gr_arc (start {k(*s)}) (mid {k(*mid)}) (end {k(*e)}) '
                     f'(layer "Edge.Cuts"))')
    for i, (x, y) in enumerate(m.mount_holes_xy_mm()):
        x += shift_hole if i == 0 else 0.0
        dia = m.mount_clearance_diameter_mm
        items.append(f'(footprint "MountingHole_M2" (layer "F.Cu") (at {k(x, y)}) '
                     f'(pad "" np_thru_hole circle (at 0 0) (size {dia} {dia}) (drill {dia}) '
                     f'(layers "*.Cu")))')
    px, py = part_xy
    items.append(f'(footprint "FFC" (layer "F.Cu") (at {k(px, py)} 90) '
                 f'(pad "1" smd rect (at 0 0 90) (size 1.0 {part_w}) (layers "F.Cu")))')
    return ("(kicad_pcb (version 20240108) (generator \"test\")\n"
            f"  (setup (aux_axis_origin {ox} {oy}))\n  " + "\n  ".join(items) + "\n)\n")


def test_a_board_drawn_from_the_contract_fits(shipped, tmp_path):
    f = tmp_path / "ok.kicad_pcb"
    f.write_text(contract_board(shipped.dims))
    assert pcb_fit_problems(read_board(f), shipped.dims, shipped.parts.base) == []


@pytest.mark.parametrize("kwargs, message", [
    ({"shift_hole": 0.3}, "no board hole"),
    ({"part_xy": (0.0, 5.5)}, "hit the base outside the pocket"),     # a part under the apex
    ({"part_w": 10.5}, "hit the base outside the pocket"),            # wider than the pocket
])
def test_a_board_that_does_not_fit_is_caught(shipped, tmp_path, kwargs, message):
    f = tmp_path / "bad.kicad_pcb"
    f.write_text(contract_board(shipped.dims, **kwargs))
    problems = pcb_fit_problems(read_board(f), shipped.dims, shipped.parts.base)
    assert any(message in p for p in problems), problems
