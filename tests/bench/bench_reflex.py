"""Reflexes on the simulated fingertip: contact latency (force-only 15 Hz, 80 Hz, fused),
false and missed contacts, slip detection and holding, the fastest safe pinch.

Seeds and ranges (every figure below is from these):
- contacts: 500 touches, sessions of 5 with seeds 1..100 (``touch_sessions(500, 5, 1)``):
  approach 5-80 mm/s, peak force 0.2-3 N, object stiffness 0.25-3 N/mm (all log-uniform),
  contact height 0-4 mm below the nail tip (a quarter on the nail), motor noise from the
  finger's own joint, speech at 65 dB SPL half of the time, room noise 50 dB SPL, mains
  hum; virtual strain unit 100 with a linear calibration;
- false contacts: 60 sessions of 10 s (seeds 1000..1059) of the hand moving without touching
  (random joint moves up to 3 rad/s), speech and room noise as above; taps: the same with
  knocks on the robot at 6 a minute (seeds 2000..2029), reported per tap;
- pinch speed: the pinch recipe (``tasks.pinch.pinch`` with ``approach_speed_mm_s``) on the
  pinch trials' worlds (seeds 0..24, ``make_world``: placements 0.3-1.3 mm plus 0.15 s of
  travel, contact heights 1-4 mm, angles +-20 deg; piezo audio seeded by the trial), tofu
  and chip at the paper's 0.5 / 0.1 N, closing speeds 0.5-32 mm/s, force-only 15 Hz,
  force-only 80 Hz and fused contact (:mod:`fingertip.sim.pinch_speed`), two processes;
- latency budget: the firmware ELF at 115200, 500000 and 1000000 baud, 4 and 16 channels,
  20 simulated seconds each (``make -C firmware bauds``);
- slip: 100 holds (seeds 0..99, ``slip_trials(100, 0)``) of five objects in turn
  (:data:`~fingertip.sim.physics.grasp.HELD_OBJECTS`: 50-250 g, friction 0.35-0.9), two
  fingertips (virtual units 100, 101) gripping at 1.15-1.6 x the least force that holds
  (log-uniform), a load of 20-80 % of the object's mass added in 5 ms after 0.3 s, held 1 s;
  each trial with the fused reflex, the force-only reflex and none (the hold's Coulomb law,
  safety 1.25, rated load 1.0), and with the fused reflex and the earlier proportional law;
  ``run.py reflex:slip`` runs this part alone.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from fingertip.device.fingertip import DEVICE_RATES
from fingertip.sim import latency_budget as lb
from fingertip.sim import pinch_speed as ps

from fingertip.sim.physics.touch import Session, render_session, touch_sessions
from fingertip.sim.reflex_eval import run_session, summarise
from fingertip.sim.world.slip import run_hold_trial, slip_trials

CONTACTS = 500
PER_SESSION = 5
CONTACT_SEED = 1
FREE_SESSIONS = 60
FREE_S = 10.0
TAP_SESSIONS = 30
TAP_RATE_HZ = 0.1


def contact_figures(contacts: int = CONTACTS, free_sessions: int = FREE_SESSIONS,
                    tap_sessions: int = TAP_SESSIONS) -> dict[str, float]:
    sessions = touch_sessions(contacts, PER_SESSION, CONTACT_SEED, speech_db=65.0)
    res: dict[str, list] = {"force15": [], "force80": [], "fused": []}
    for s in sessions:
        audio = render_session(s)
        res["force15"].append(run_session(s, "force", 15))
        res["force80"].append(run_session(s, "force", 80))
        res["fused"].append(run_session(s, "fused", 80, audio=audio))
    out: dict[str, float] = {}
    for mode, rs in res.items():
        m = summarise(rs)
        out[f"contact_latency_p50_ms_{mode}"] = round(m.get("p50_ms", float("nan")), 3)
        out[f"contact_latency_p99_ms_{mode}"] = round(m.get("p99_ms", float("nan")), 3)
        out[f"contact_missed_{mode}"] = m["missed"]
    fused = summarise(res["fused"])
    out["contact_missed"] = fused["missed"]
    out["contact_trials"] = fused["contacts"]
    out["contact_piezo_share"] = round(fused["piezo_share"], 4)
    out["contact_false_in_touch_sessions"] = fused["false"]
    free = [run_session(Session(FREE_S, [], 1000 + i, free_motion=True, speech_db=65.0),
                        "fused", 80) for i in range(free_sessions)]
    f = summarise(free)
    out["contact_false_per_min"] = round(f["false"] / f["minutes"], 3)
    out["contact_false_confirmed_per_min"] = round(f["false_confirmed"] / f["minutes"], 3)
    out["contact_free_minutes"] = round(f["minutes"], 2)
    tapped = [Session(FREE_S, [], 2000 + i, free_motion=True, speech_db=65.0,
                      tap_rate_hz=TAP_RATE_HZ) for i in range(tap_sessions)]
    tr = [run_session(s, "fused", 80) for s in tapped]
    taps = sum(len(s.tap_s) for s in tapped)
    t = summarise(tr)
    out["contact_taps"] = taps
    out["contact_false_per_tap"] = round(t["false"] / max(taps, 1), 3)
    out["contact_false_confirmed_taps"] = t["false_confirmed"]
    return out


ROOT = Path(__file__).resolve().parents[2]
SLIP_TRIALS = 100


def slip_figures(trials: int = SLIP_TRIALS) -> dict[str, float]:
    rows: dict[str, list[dict]] = {"fused": [], "force": [], "none": []}
    old: list[dict] = []
    for tr in slip_trials(trials, 0):
        for reflex, rs in rows.items():
            rs.append(run_hold_trial(tr, reflex))
        # The earlier proportional raise on the same holds, side by side.
        old.append(run_hold_trial(tr, "fused", law="proportional"))
    out: dict[str, float] = {"slip_trials": trials,
                             "slip_slipped_no_reflex": sum(r["slipped"] for r in rows["none"])}
    for reflex, rs in rows.items():
        tag = {"fused": "", "force": "_force_only", "none": "_no_reflex"}[reflex]
        out[f"slip_hold_success{tag}"] = round(float(np.mean([r["held"] for r in rs])), 3)
        out[f"slip_mean_grip_n{tag}"] = round(float(np.mean([r["mean_grip_n"] for r in rs])),
                                              3)
        lat = [r["latency_s"] for r in rs if r["latency_s"] is not None]
        if reflex != "none":
            out[f"slip_latency_p50_ms{tag}"] = round(float(np.median(lat)) * 1e3, 2) \
                if lat else float("nan")
            out[f"slip_detected{tag}"] = len(lat)
            out[f"slip_false_before_load{tag}"] = sum(r["false_before_load"] for r in rs)
    out["slip_slipped"] = sum(r["slipped"] for r in rows["fused"])
    out["slip_hold_success_proportional"] = round(float(np.mean([r["held"] for r in old])), 3)
    out["slip_mean_grip_n_proportional"] = round(
        float(np.mean([r["mean_grip_n"] for r in old])), 3)
    return out


PINCH_SPEEDS = [0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0, 24.0, 32.0]
PINCH_PNG = ROOT / "docs" / "img" / "pinch_speed.png"
_tables: dict[str, str] = {}


PINCH_WORKERS = 2


def pinch_figures(trials: int = 25, png: Path | None = PINCH_PNG) -> dict[str, float]:
    t0 = time.monotonic()
    result = ps.sweep(PINCH_SPEEDS, trials, 0, workers=PINCH_WORKERS)
    seconds = time.monotonic() - t0
    if png is not None:
        ps.plot(result, png, trials)
    title = ("Reflexes: the pinch recipe's closing speed against success (simulated hand, "
             "seeds 0-24)")
    curve = png.relative_to(ROOT) if png else "-"
    _tables[title] = ps.table(result, trials) + f"\nCurve: {curve}\n"
    best = {m: ps.max_safe_speed(c, trials) for m, c in result.items()}
    out = {f"pinch_max_speed_mm_s_{m}": b for m, b in best.items()}
    out["pinch_max_speed_ratio"] = round(best["fused"] / best["force15"], 3) \
        if best["force15"] else float("nan")
    out["pinch_speed_sweep_s"] = round(seconds, 1)
    return out


def latency_figures(sim_seconds: float = 20.0) -> dict[str, float]:
    """The real firmware in simavr at each rate, 4 and 16 channels (``make -C firmware
    bauds`` first)."""
    rows = [lb.measure(ch, baud, sim_seconds).row() for ch in (4, 16) for baud in lb.RATES]
    _tables["Reflexes: latency budget of a force frame, firmware in simavr over the pty"] = \
        lb.table(rows) + (
            "\nconversion -> read and -> last bit sent: simulated AVR cycles (exact); host "
            "read -> callback: wall clock on this shared machine. A real Uno adds its USB "
            "bridge between the pin and the host's read (not simulated).\n")
    out: dict[str, float] = {}
    for r in rows:
        tag = f"{r['channels']}ch_{r['baud']}"
        out[f"frame_to_callback_p99_ms_{tag}"] = r["total_p99_ms"]
        out[f"frame_sent_p99_ms_{tag}"] = round(r["ready_to_sent_p99_us"] / 1e3, 4)
    default = DEVICE_RATES[0]
    out["frame_to_callback_p99_ms"] = out[f"frame_to_callback_p99_ms_4ch_{default}"]
    out["uart_default_baud"] = default
    return out


PARTS = {"contact": contact_figures, "slip": slip_figures, "pinch": pinch_figures,
         "latency": latency_figures}
"""Parts that ``run.py reflex:PART`` runs alone (the whole bench takes about 15 min)."""


def run() -> dict[str, float]:
    return {k: v for part in PARTS.values() for k, v in part().items()}


def tables(figures: dict) -> dict[str, str]:
    return dict(_tables)


DESCRIPTION = {
    "frame_to_callback_p99_ms": ("HX711 conversion ready -> frame's last bit on the UART "
                                 "(firmware in simavr, exact) + host read -> user callback "
                                 "(wall clock), p99, 4 channels at the default rate",
                                 ("<=", 3.0)),
    "uart_default_baud": ("the firmware's UART rate (pins.h; the host also tries 115200)",
                          None),
    "pinch_max_speed_ratio": ("highest closing speed keeping 25/25 tofu and 25/25 chips intact "
                              "with fused contact, over the paper-style force-only 15 Hz one",
                              (">=", 3.0)),
    "pinch_max_speed_mm_s_fused": ("highest 25/25-safe closing speed, fused contact: the "
                                   "pinch recipe on the simulated hand (grid 0.5-32 mm/s; "
                                   "seeds 0-24; command 2 ms and braking 5000 mm/s^2 "
                                   "assumed)", None),
    "pinch_speed_sweep_s": ("wall-clock time of the whole speed sweep (two processes)", None),
    "pinch_max_speed_mm_s_force80": ("the same, force-only 80 Hz", None),
    "pinch_max_speed_mm_s_force15": ("the same, force-only 15 Hz (the paper's rate)", None),
    "slip_latency_p50_ms": ("true gross-slip onset to the first slip_onset (fused: piezo "
                            "bursts + force ratio; the recipe reads audio once per 12.5 ms "
                            "frame), median over the holds that slipped", ("<=", 20.0)),
    "slip_latency_p50_ms_force_only": ("the same, force ratio alone", None),
    "slip_hold_success": ("share of the 100 holds whose object stayed in the hand (slid < 10 "
                          "mm) after the load, with the fused slip reflex", (">=", 0.95)),
    "slip_hold_success_force_only": ("the same, force-ratio reflex", None),
    "slip_hold_success_proportional": ("the same holds, fused reflex with the earlier "
                                       "proportional raise (+50 %, then the ratio rule)",
                                       None),
    "slip_mean_grip_n_proportional": ("mean normal force per finger, that earlier law",
                                      None),
    "slip_hold_success_no_reflex": ("the same, keeping the initial grip force", None),
    "slip_mean_grip_n": ("mean normal force per finger over the holds, fused reflex", None),
    "slip_mean_grip_n_force_only": ("the same, force-only reflex", None),
    "slip_mean_grip_n_no_reflex": ("the same, no reflex", None),
    "slip_trials": ("simulated holds", None),
    "slip_slipped": ("holds in which the object slipped at all, fused reflex", None),
    "slip_slipped_no_reflex": ("holds in which the object slipped without a reflex", None),
    "slip_detected": ("holds with a slip whose slip_onset came after the load, fused", None),
    "slip_detected_force_only": ("the same, force only", None),
    "slip_false_before_load": ("slip_onset events before any load (false), fused, all holds",
                               None),
    "slip_false_before_load_force_only": ("the same, force only", None),
    "contact_latency_p99_ms_fused": (
        "true contact to the user's callback, p99, fused piezo + force (80 Hz frames); 500 "
        "simulated touches (seeds 1-100, 5-80 mm/s, 0.2-3 N, 0.25-3 N/mm, heights 0-4 mm, "
        "motor noise, speech 65 dB); 64-sample audio blocks + 1 ms audio path (assumed)",
        ("<=", 5.0)),
    "contact_latency_p50_ms_fused": ("the same, median", None),
    "contact_latency_p99_ms_force15": ("the same touches, force frames alone at 15 Hz (the "
                                       "paper's rate), p99", None),
    "contact_latency_p50_ms_force15": ("force-only 15 Hz, median", None),
    "contact_latency_p99_ms_force80": ("force-only 80 Hz, p99", None),
    "contact_latency_p50_ms_force80": ("force-only 80 Hz, median", None),
    "contact_missed": ("true contacts without a contact event within 400 ms, fused, of 500",
                       ("<=", 0)),
    "contact_missed_fused": ("the same (fused)", None),
    "contact_missed_force15": ("missed, force-only 15 Hz", None),
    "contact_missed_force80": ("missed, force-only 80 Hz", None),
    "contact_trials": ("simulated touches", None),
    "contact_piezo_share": ("share of the fused contacts first heard by the piezo (the rest "
                            "by the force)", None),
    "contact_false_in_touch_sessions": ("contact events matching no touch during the 500 "
                                        "touches (all retracted by the force)", None),
    "contact_false_per_min": (
        "contact events (piezo, before the force could retract them) per minute while the "
        "hand moves without touching: 10 simulated minutes (seeds 1000-1059), joint moves up "
        "to 3 rad/s, speech 65 dB, room 50 dB, hum; the hand gates the piezo 80 ms at each "
        "move start", ("<=", 0.5)),
    "contact_false_confirmed_per_min": ("of those, not retracted by the force", ("<=", 0.5)),
    "contact_free_minutes": ("simulated minutes of the false-contact run", None),
    "contact_taps": ("knocks on the robot (6 a minute, seeds 2000-2029, median 30 mN at the "
                     "nail)", None),
    "contact_false_per_tap": ("provisional contact events per knock on the robot (the piezo "
                              "hears a knock like a soft touch; the force retracts them)",
                              None),
    "contact_false_confirmed_taps": ("knocks taken for contacts after the force check",
                                     ("<=", 0)),
}


if __name__ == "__main__":
    for k, v in contact_figures(50, 6, 6).items():
        print(k, v)
    _ = np
