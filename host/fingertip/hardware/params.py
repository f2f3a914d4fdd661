"""The fingertip's parameters: ``fingertip.toml`` (shipped in this package) as frozen dataclasses.

The TOML file is the one source of truth for the fingertip's dimensions, parts and their
mechanical and electrical properties: the simulator (``fingertip.sim.physics``), the CAD
(``mechanical/fingertip_cad``) and the PCB generator (``pcb/tools``) all read it here. Field
names equal the TOML keys (units in the names); SI values that the models need are derived
properties. The file is read by :mod:`.tables` (unknown or missing keys are errors).

Standard library only: the PCB generator loads this package by path.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

from .tables import read_tables, tomllib

PARAMS_FILE = "fingertip.toml"
SCHEMA = 1


def params_path() -> Path:
    """Path of the shipped TOML file (for tools such as the CAD that read it directly)."""
    return Path(__file__).with_name(PARAMS_FILE)


@dataclass(frozen=True)
class Geometry:
    outer_width_mm: float
    outer_height_mm: float
    base_height_mm: float
    prism_side_mm: float
    prism_core_side_mm: float
    prism_length_mm: float
    cap_roof_mm: float
    cap_gap_mm: float
    skin_mm: float
    nail_proud_mm: float
    nail_tip_z_mm: float
    gauge_center_z_mm: float

    @property
    def cap_wall_mm(self) -> float:
        """Cap wall thickness left by the envelope, the skin, the gap and the prism."""
        return (self.outer_width_mm - 2 * self.skin_mm - 2 * self.cap_gap_mm
                - self.prism_side_mm) / 2

    def lever_m(self, contact_height_mm: float = 0.0) -> float:
        """Distance from the gauge centre to a contact ``contact_height_mm`` below the nail."""
        return (self.nail_tip_z_mm - contact_height_mm - self.gauge_center_z_mm) * 1e-3


@dataclass(frozen=True)
class Materials:
    pla_modulus_gpa: float
    pla_poisson: float
    pla_cte_per_k: float
    tpu_modulus_mpa: float
    tpu_poisson: float


@dataclass(frozen=True)
class Base:
    rotational_stiffness_nm_per_rad: float
    moment_shunt: float
    moment_shunt_threefold: float
    moment_shunt_per_newton: float


@dataclass(frozen=True)
class Gauge:
    model: str
    resistance_ohm: float
    grid_length_mm: float
    grid_width_mm: float
    backing_length_mm: float
    backing_width_mm: float
    gauge_factor: float
    transverse_sensitivity: float
    glue_transfer: float
    self_compensation_cte_per_k: float
    gauge_factor_tc_per_k: float


@dataclass(frozen=True)
class Bridge:
    configuration: str
    completion_ohm: float
    completion_tolerance: float
    lead_resistance_ohm: float


@dataclass(frozen=True)
class HX711:
    avdd_v: float
    excitation_v: float
    gain: int
    bits: int
    full_scale_fraction_of_avdd: float
    noise_nv_rms_10sps: float
    noise_nv_rms_80sps: float
    rates_sps: tuple[int, ...]
    paper_stream_hz: float

    @property
    def full_scale_v(self) -> float:
        """Full-scale differential input at this gain: +-0.5 * AVDD / gain."""
        return self.full_scale_fraction_of_avdd * self.avdd_v / self.gain

    @property
    def counts_per_volt(self) -> float:
        return 2 ** (self.bits - 1) / self.full_scale_v

    @property
    def count_max(self) -> int:
        return 2 ** (self.bits - 1) - 1

    @property
    def count_min(self) -> int:
        return -(2 ** (self.bits - 1))

    def noise_v_rms(self, rate_sps: int) -> float:
        if rate_sps not in self.rates_sps:
            raise ValueError(f"HX711 rate must be one of {self.rates_sps}, not {rate_sps}")
        return (self.noise_nv_rms_10sps if rate_sps == 10 else self.noise_nv_rms_80sps) * 1e-9


@dataclass(frozen=True)
class Variation:
    gauge_angle_deg: float
    gauge_z_mm: float
    gauge_lateral_mm: float
    gauge_factor_rel: float
    glue_transfer: float
    modulus_rel: float
    prism_side_mm: float
    gauge_resistance_rel: float
    completion_rel: float
    glue_prestrain_mean_ue: float
    glue_prestrain_ue: float
    hx711_offset_uv: float
    moment_shunt: float
    hysteresis_rel: float
    creep_rel: float
    creep_tau_rel: float
    apparent_strain_ue_per_k: float
    span_tc_per_k: float
    noise_rel: float


@dataclass(frozen=True)
class Hysteresis:
    operators: int
    radius_max_ue: float
    gain: float


@dataclass(frozen=True)
class Creep:
    fraction: float
    tau_s: float


@dataclass(frozen=True)
class Thermal:
    reference_c: float
    span_tc_per_k: float


@dataclass(frozen=True)
class Piezo:
    diameter_mm: float
    thickness_mm: float
    capacitance_nf: float
    sensitivity_v_per_n: float


@dataclass(frozen=True)
class Preamp:
    input_resistance_mohm: float
    gain: float
    noise_nv_per_rthz: float
    rail_v: float


@dataclass(frozen=True)
class SoundCard:
    sample_rate_hz: int
    full_scale_v: float
    bits: int
    noise_dbfs_rms: float
    antialias_hz: float


@dataclass(frozen=True)
class CapModes:
    frequency_hz: tuple[float, ...]
    damping: tuple[float, ...]
    weight: tuple[float, ...]
    direct: float


@dataclass(frozen=True)
class Mains:
    frequency_hz: float
    harmonics: tuple[int, ...]
    amplitude_uv_rms: tuple[float, ...]


@dataclass(frozen=True)
class Mount:
    """The base's footprint and what the fingertip PCB and the finger link meet there."""

    base_side_mm: float
    base_corner_radius_mm: float
    mount_hole_radius_mm: float
    mount_hole_angles_deg: tuple[float, ...]
    mount_clearance_diameter_mm: float
    mount_pilot_diameter_mm: float
    pcb_thickness_mm: float
    pocket_depth_mm: float
    wire_hole_x_mm: tuple[float, ...]
    wire_hole_y_mm: tuple[float, ...]
    wire_hole_diameter_mm: float
    ffc_pins: int
    ffc_pitch_mm: float

    @property
    def base_inradius_mm(self) -> float:
        """Distance from the prism axis to each flat edge of the triangle."""
        return self.base_side_mm / (2 * math.sqrt(3))

    def mount_holes_xy_mm(self) -> list[tuple[float, float]]:
        """Centres of the M2 mounting holes."""
        r = self.mount_hole_radius_mm
        return [(r * math.cos(math.radians(a)), r * math.sin(math.radians(a)))
                for a in self.mount_hole_angles_deg]

    def wire_holes_xy_mm(self) -> list[tuple[float, float]]:
        return list(zip(self.wire_hole_x_mm, self.wire_hole_y_mm, strict=True))


@dataclass(frozen=True)
class Cad:
    """Dimensions that only the CAD needs (mechanical/fingertip_cad): printed walls, screws,
    the piezo seat, wire channels, the base's pocket and the two-part mold."""

    min_wall_mm: float
    prism_embed_mm: float
    cap_base_clearance_mm: float
    nail_width_mm: float
    nail_height_mm: float
    screw_length_mm: float
    screw_clearance_diameter_mm: float
    screw_head_diameter_mm: float
    screw_pilot_diameter_mm: float
    screw_pilot_depth_mm: float
    piezo_seat_clearance_mm: float
    piezo_seat_depth_mm: float
    piezo_wire_hole_diameter_mm: float
    wire_channel_width_mm: float
    wire_channel_depth_mm: float
    mount_pilot_depth_mm: float
    pocket_wall_mm: float
    mold_wall_mm: float
    mold_key_diameter_mm: float
    mold_key_length_mm: float
    mold_key_clearance_mm: float
    mold_pour_diameter_mm: float
    mold_vent_diameter_mm: float

    @property
    def countersink_depth_mm(self) -> float:
        """Depth of the 90-degree countersink for the cap screw's head."""
        return (self.screw_head_diameter_mm - self.screw_clearance_diameter_mm) / 2


_SECTIONS: dict[str, type] = {
    "geometry": Geometry, "materials": Materials, "base": Base, "gauge": Gauge,
    "bridge": Bridge, "hx711": HX711, "variation": Variation, "hysteresis": Hysteresis,
    "creep": Creep, "thermal": Thermal, "piezo": Piezo, "preamp": Preamp,
    "soundcard": SoundCard, "cap_modes": CapModes, "mains": Mains, "mount": Mount,
    "cad": Cad,
}


@dataclass(frozen=True)
class FingertipParams:
    geometry: Geometry
    materials: Materials
    base: Base
    gauge: Gauge
    bridge: Bridge
    hx711: HX711
    variation: Variation
    hysteresis: Hysteresis
    creep: Creep
    thermal: Thermal
    piezo: Piezo
    preamp: Preamp
    soundcard: SoundCard
    cap_modes: CapModes
    mains: Mains
    mount: Mount
    cad: Cad

    # --- derived mechanics (SI) -----------------------------------------------------------

    @property
    def modulus_pa(self) -> float:
        return self.materials.pla_modulus_gpa * 1e9

    @property
    def flexural_rigidity_nm2(self) -> float:
        """EI of the (possibly composite) square section: PLA core + TPU shell."""
        return section_rigidity(self.geometry.prism_side_mm * 1e-3,
                                self.geometry.prism_core_side_mm * 1e-3, self.modulus_pa,
                                self.materials.tpu_modulus_mpa * 1e6)

    @property
    def strain_per_newton(self) -> float:
        """Nominal surface strain per newton at the gauge, contact at the nail tip."""
        c = self.geometry.prism_side_mm * 1e-3 / 2
        return self.geometry.lever_m(0.0) * c / self.flexural_rigidity_nm2

    @property
    def counts_per_strain(self) -> float:
        """Small-signal HX711 counts per unit strain (quarter bridge, nominal gauge)."""
        h = self.hx711
        return h.excitation_v * self.gauge.gauge_factor / 4 * h.counts_per_volt

    def replace(self, **sections: dict[str, Any]) -> FingertipParams:
        """A copy with some fields changed: ``p.replace(hysteresis={"gain": 0.0})``."""
        changes = {}
        for name, values in sections.items():
            changes[name] = dataclasses.replace(getattr(self, name), **values)
        return dataclasses.replace(self, **changes)


def section_rigidity(side_m: float, core_side_m: float, e_core: float, e_shell: float) -> float:
    """EI of a square section (side ``side_m``) with a square core of a stiffer material."""
    i_out, i_core = side_m ** 4 / 12, core_side_m ** 4 / 12
    return e_core * i_core + e_shell * (i_out - i_core)


def from_dict(data: dict[str, Any], where: str = PARAMS_FILE) -> FingertipParams:
    p = FingertipParams(**read_tables(data, _SECTIONS, where, SCHEMA))
    _check(p, where)
    return p


def _check(p: FingertipParams, where: str) -> None:
    g = p.geometry
    problems = []
    if g.cap_wall_mm <= 0:
        problems.append(f"no room for the cap wall ({g.cap_wall_mm:.2f} mm)")
    if not 0 < g.prism_core_side_mm <= g.prism_side_mm:
        problems.append("prism_core_side_mm must be in (0, prism_side_mm]")
    if p.gauge.backing_width_mm > g.prism_side_mm:
        problems.append("the gauge backing is wider than the prism face")
    if g.gauge_center_z_mm - p.gauge.backing_length_mm / 2 < 0:
        problems.append("the gauge backing runs past the prism root")
    if not g.gauge_center_z_mm < g.prism_length_mm <= g.nail_tip_z_mm:
        problems.append("need gauge_center_z_mm < prism_length_mm <= nail_tip_z_mm")
    n = len(p.cap_modes.frequency_hz)
    if len(p.cap_modes.damping) != n or len(p.cap_modes.weight) != n:
        problems.append("cap_modes lists differ in length")
    if len(p.mains.harmonics) != len(p.mains.amplitude_uv_rms):
        problems.append("mains harmonics and amplitudes differ in length")
    if len(p.mount.wire_hole_x_mm) != len(p.mount.wire_hole_y_mm):
        problems.append("mount wire_hole_x_mm and wire_hole_y_mm differ in length")
    if p.bridge.configuration != "quarter":
        problems.append("only the quarter bridge is modelled")
    problems += _check_cad(p)
    if problems:
        raise ValueError(f"{where}: " + "; ".join(problems))


def _check_cad(p: FingertipParams) -> list[str]:
    """What makes a parameter set impossible to print or assemble (mechanical/ builds it)."""
    g, c, m = p.geometry, p.cad, p.mount
    wall = c.min_wall_mm
    problems = []
    stack = g.base_height_mm + g.prism_length_mm + g.cap_roof_mm + p.piezo.thickness_mm \
        + g.skin_mm
    if abs(stack - g.outer_height_mm) > 1e-6:
        problems.append(f"base + prism + cap roof + piezo + skin = {stack:.3f} mm, not "
                        f"outer_height_mm = {g.outer_height_mm}")
    if 0 < g.cap_wall_mm < wall:
        problems.append(f"the cap wall ({g.cap_wall_mm:.2f} mm) is thinner than "
                        f"min_wall_mm ({wall})")
    if g.cap_gap_mm <= 0 or g.skin_mm <= 0 or g.nail_proud_mm <= 0:
        problems.append("cap_gap_mm, skin_mm and nail_proud_mm must be positive")
    under_head = g.cap_roof_mm - c.piezo_seat_depth_mm - c.countersink_depth_mm
    if under_head < wall:
        problems.append(f"the cap roof leaves {under_head:.2f} mm under the screw's countersink "
                        f"(min_wall_mm {wall})")
    if c.screw_head_diameter_mm <= c.screw_clearance_diameter_mm:
        problems.append("screw_head_diameter_mm must exceed screw_clearance_diameter_mm")
    around_pilot = (g.prism_side_mm - c.screw_pilot_diameter_mm) / 2 - c.wire_channel_depth_mm
    if around_pilot < wall:
        problems.append(f"the prism leaves {around_pilot:.2f} mm around the screw's pilot hole")
    thread = c.screw_length_mm - (g.cap_roof_mm - c.piezo_seat_depth_mm)
    if not 1.5 * c.screw_pilot_diameter_mm <= thread <= c.screw_pilot_depth_mm - 0.5:
        problems.append(f"the cap screw engages {thread:.2f} mm: need 1.5 x the pilot diameter "
                        f"and 0.5 mm short of screw_pilot_depth_mm ({c.screw_pilot_depth_mm})")
    if c.screw_pilot_depth_mm > g.prism_length_mm - wall:
        problems.append("the screw's pilot hole runs out of the prism")
    cap_outer = g.outer_width_mm - 2 * g.skin_mm
    seat = p.piezo.diameter_mm + 2 * c.piezo_seat_clearance_mm
    if seat > cap_outer - 2 * wall:
        problems.append(f"the piezo seat ({seat:.2f} mm) does not fit on the cap roof "
                        f"({cap_outer:.2f} mm)")
    if not 0 <= c.piezo_seat_depth_mm < p.piezo.thickness_mm:
        problems.append("piezo_seat_depth_mm must be in [0, piezo thickness)")
    if c.piezo_wire_hole_diameter_mm >= g.cap_gap_mm:
        problems.append("the piezo's wire hole must be narrower than the cap gap it opens into")
    nail_bottom = g.nail_tip_z_mm - c.nail_height_mm
    if nail_bottom < c.cap_base_clearance_mm or g.nail_tip_z_mm > g.prism_length_mm \
            + g.cap_roof_mm:
        problems.append("the nail must lie on the cap's side (between its rim and its top edge)")
    if not 0 < c.nail_width_mm <= cap_outer - 2 * wall:
        problems.append("nail_width_mm must be positive and leave min_wall_mm at the cap's edges")
    above_nail = g.prism_length_mm + g.cap_roof_mm + p.piezo.thickness_mm + g.skin_mm \
        - g.nail_tip_z_mm
    if above_nail < c.mold_vent_diameter_mm + wall:
        problems.append("no room for the mold's top vent between the nail and the skin's top")
    if c.cap_base_clearance_mm < max(g.cap_gap_mm, wall):
        problems.append("cap_base_clearance_mm must be at least the cap gap and min_wall_mm "
                        "(the mold's floor fills it)")
    if c.prism_embed_mm <= 0 or c.prism_embed_mm + m.pocket_depth_mm + wall \
            > g.base_height_mm:
        problems.append("the prism's root, the pocket and min_wall_mm do not fit in "
                        "base_height_mm")
    if not 0 < c.mount_pilot_depth_mm <= g.base_height_mm - wall:
        problems.append("mount_pilot_depth_mm must leave min_wall_mm under the base's top")
    if m.base_inradius_mm - g.prism_side_mm / 2 - c.wire_channel_width_mm < wall:
        problems.append("the base is too small around the prism and its wire channels")
    for name in ("mold_key_diameter_mm", "mold_pour_diameter_mm"):
        if getattr(c, name) + 2 * wall > c.mold_wall_mm:
            problems.append(f"{name} + 2 x min_wall_mm exceeds mold_wall_mm")
    if not 0 < c.mold_key_clearance_mm < c.mold_key_diameter_mm / 4:
        problems.append("mold_key_clearance_mm must be positive and small")
    if c.wire_channel_depth_mm <= 0 or c.wire_channel_width_mm <= 0:
        problems.append("wire channels need a positive width and depth")
    return problems


def load(path: str | Path | None = None) -> FingertipParams:
    """Read the parameters (the shipped file when ``path`` is None; cached then)."""
    if path is None:
        return _default()
    path = Path(path)
    return from_dict(tomllib.loads(path.read_text(encoding="utf-8")), str(path))


@lru_cache(maxsize=1)
def _default() -> FingertipParams:
    return from_dict(tomllib.loads(params_path().read_text(encoding="utf-8")))
