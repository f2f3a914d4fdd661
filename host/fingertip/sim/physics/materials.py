"""Surfaces the fingernail slides over: the paper's seven materials (and a paper-cup wall).

Each surface is described by what the nail feels, as a dynamic force at the nail:

- micro-roughness: a spatial spectrum centred on ``wavelength_um`` (log-Gaussian of width
  ``bandwidth_oct``, plus a broadband ``tail``); sliding at speed v turns a wavelength L into
  a temporal frequency v / L, so the spectrum moves up with speed;
- macro texture (weave, mesh, ridges): a period ``period_mm`` that modulates the roughness
  (``depth``) and may add a click at each feature (``click_n``, ``click_ms``);
- stick-slip: slip events every ``slip_mm`` (at 1 N; proportional to the normal force) with
  amplitude ``stick_slip_n`` (per newton);
- soft surfaces damp high frequencies (``lowpass_hz``).

Amplitudes are given at the reference speed and normal force (20 mm/s, 1 N) and scale as
(v / v_ref)^0.5 and (N / N_ref)^0.7. The numbers are ours, chosen so the signatures are
distinct but overlap, with copper tape and wax paper deliberately close (both smooth), as the
paper's confusion matrix shows. The paper's "Flush Fabric" is read as plush fabric.
"""
from __future__ import annotations

from dataclasses import dataclass

REF_SPEED_MM_S = 20.0
REF_NORMAL_N = 1.0


@dataclass(frozen=True)
class Material:
    name: str
    roughness_n: float
    wavelength_um: float
    bandwidth_oct: float
    tail: float
    lowpass_hz: float | None
    friction: float
    period_mm: float | None = None
    depth: float = 0.0
    period_jitter: float = 0.05
    click_n: float = 0.0
    click_ms: float = 0.3
    stick_slip_n: float = 0.0
    slip_mm: float = 0.2
    description: str = ""


MATERIALS: dict[str, Material] = {m.name: m for m in (
    Material("tpu", roughness_n=0.004, wavelength_um=45, bandwidth_oct=1.2, tail=0.05,
             lowpass_hz=1800, friction=0.9, stick_slip_n=0.012, slip_mm=0.15,
             description="rubbery, high friction: stick-slip bursts, dull"),
    Material("expanded_plastic", roughness_n=0.0025, wavelength_um=12, bandwidth_oct=1.0,
             tail=0.1, lowpass_hz=None, friction=0.35, period_mm=3.0, depth=0.3,
             period_jitter=0.03, click_n=0.06, click_ms=0.25,
             description="plastic mesh: a sharp click at every strand"),
    Material("copper_tape", roughness_n=0.0016, wavelength_um=7, bandwidth_oct=1.3, tail=0.12,
             lowpass_hz=None, friction=0.3,
             description="smooth metal foil: faint, bright hiss"),
    Material("coarse_fabric", roughness_n=0.012, wavelength_um=30, bandwidth_oct=1.0, tail=0.08,
             lowpass_hz=5000, friction=0.5, period_mm=1.2, depth=0.8, period_jitter=0.08,
             click_n=0.01, click_ms=1.0,
             description="coarse weave: loud, modulated at the yarn period"),
    Material("plush_fabric", roughness_n=0.006, wavelength_um=120, bandwidth_oct=1.2, tail=0.05,
             lowpass_hz=700, friction=0.6, period_mm=0.8, depth=0.5, period_jitter=0.3,
             description="soft pile: low rustle, high frequencies damped"),
    Material("wax_paper", roughness_n=0.0019, wavelength_um=8.5, bandwidth_oct=1.3, tail=0.12,
             lowpass_hz=9000, friction=0.25, stick_slip_n=0.0012, slip_mm=0.6,
             description="smooth waxed paper: faint hiss, a little duller than copper"),
    Material("textured_fabric", roughness_n=0.008, wavelength_um=20, bandwidth_oct=1.0,
             tail=0.08, lowpass_hz=4000, friction=0.45, period_mm=0.6, depth=0.6,
             period_jitter=0.06, click_n=0.015, click_ms=0.5,
             description="patterned fabric: mid-band, ridges every 0.6 mm"),
)}

PAPER_SEVEN = ("tpu", "expanded_plastic", "copper_tape", "coarse_fabric", "plush_fabric",
               "wax_paper", "textured_fabric")
"""The paper's seven materials, in its order."""

CUP_WALL = Material("paper_cup", roughness_n=0.003, wavelength_um=15, bandwidth_oct=1.1,
                    tail=0.1, lowpass_hz=8000, friction=0.35,
                    description="outer wall of a paper cup")


def material(name: str) -> Material:
    key = name.strip().lower().replace(" ", "_").replace("-", "_")
    key = {"flush_fabric": "plush_fabric", "copper": "copper_tape", "wax": "wax_paper"}.get(
        key, key)
    try:
        return MATERIALS[key]
    except KeyError:
        raise ValueError(f"unknown material {name!r}; known: {', '.join(MATERIALS)}") from None
