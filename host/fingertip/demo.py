"""`fingertip demo` / `make demo`: the whole chain on a virtual fingertip, in about 30 s.

A scripted scene (a press, a slide over two materials, a slide down a stack of paper cups)
drives the physics of a virtual fingertip; its strain signals go into the real firmware in
simavr (or the same device logic built for the host, on a simulated board) and come back
through the host bridge over a pty, its piezo signal through the audio capture interface.
The bridge tares, streams (a live line in the terminal), the events are detected, and a PNG
summary is written.
"""
from __future__ import annotations

import logging
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .audio import SimulatedSource
from .audio.pcm import to_float
from .device import Fingertip, Frame
from .events import Event, contact_intervals, vibration_onsets
from .plots import session_summary
from .record import Recorder
from .sim import VirtualFirmware
from .sim.physics import CupStackSlide, Press, Script, Slide, VirtualStrainSensor, simulate
from .sim.device.calibration_rig import calibration_sweep

log = logging.getLogger(__name__)

LEAD_S = 0.4        # between arming the scene and its start
GRID_US = 2_500     # how finely the harness's analog inputs follow the physics
LOUD_DB = -58.0     # a window this loud is something sliding (the floor with hum: -59 dBFS)


def demo_scene() -> Script:
    both = ("force", "vibration")
    return Script((Press(angle_deg=20.0, peak_n=2.0, ramp_s=1.0, hold_s=0.6, pre_s=0.5,
                         post_s=0.5, signals=both),
                   Slide("coarse_fabric", duration=2.0, speed_mm_s=20.0, normal_n=1.0,
                         signals=both),
                   Slide("copper_tape", duration=2.0, speed_mm_s=20.0, normal_n=1.0,
                         signals=both),
                   CupStackSlide(signals=both)), gap_s=0.6)


@dataclass
class DemoResult:
    frames: list[Frame]
    audio: np.ndarray
    fs: float
    events: list[Event]
    png: Path
    recording: Path
    device: str
    forces: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    materials: list[tuple[float, float, str]] = field(default_factory=list)
    stats: dict = field(default_factory=dict)
    calibration: str = ""
    """The force model the calibration kept and its error, as printed: ``affine, held-out
    RMSE 0.313 N``."""
    seconds: float = 0.0
    """How long the whole run took (calibration, training, the scene), wall time."""


class _Live:
    """One status line on a terminal, refreshed a few times a second."""

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled
        self.last = 0.0

    def show(self, text: str) -> None:
        now = time.monotonic()
        if self.enabled and now - self.last > 0.2:
            self.last = now
            print("\r" + text[:150].ljust(150), end="", file=sys.stderr, flush=True)

    def done(self) -> None:
        if self.enabled:
            print(file=sys.stderr)


def _firmware_device(sensor: VirtualStrainSensor, scene, duration_s: float):
    """The real firmware in simavr, its inputs following the physics on a fine grid."""
    from .sim.device.simavr import FirmwareSim, open_fingertip

    sim = FirmwareSim(4, throttle=1.0).start()
    # Until the scene is armed: the unloaded unit, with the HX711's noise (the harness's own
    # Gaussian noise, at the level the physics gives at 80 SPS).
    idle = sensor.raw_counts_batch(np.zeros((1, 2)), 0.0, [0.0], update_state=False)[0]
    for c, v in enumerate(idle):
        sim.set(c, int(round(v)))
    sim.noise("*", float(np.mean(sensor.noise_counts_rms(80))))
    ft = open_fingertip(sim, queue_size=100_000, name="virtual fingertip (simavr)")

    def arm() -> tuple[float, float]:
        """Schedule the scene (and the idle lead-in before it, noise included); returns the
        host time at which it starts and the device time (us) at which it starts."""
        now_us = sim.time_us()
        t0_us = now_us + LEAD_S * 1e6
        host_start = time.monotonic() + LEAD_S
        ts = np.arange(-(LEAD_S - 0.05) * 1e6, duration_s * 1e6, GRID_US) * 1e-6
        f = scene.forces(np.maximum(ts, 0.0))
        f.xy[ts < 0] = 0.0
        raw = sensor.raw_counts_batch(f.xy, f.height_mm, t0_us * 1e-6 + ts, f.z, rate_sps=80)
        sim.rows(t0_us + ts * 1e6, np.rint(raw).astype(np.int64))
        return host_start, t0_us

    return ft, arm, sim.close, "the firmware ELF in simavr"


def _python_device(sensor: VirtualStrainSensor, scene, duration_s: float):
    """The firmware's device logic built for the host (VirtualFirmware) on a pty, reading
    the physics at each conversion."""
    from .sim.device.pty_device import PtyDevice

    start = {"us": 1 << 62}  # scene start in device time: far away until armed
    src_inner: dict = {}

    def source(t_us: int):
        if "fn" not in src_inner:
            return tuple(float(v) for v in sensor.raw_counts_batch(
                np.zeros((1, 2)), 0.0, [t_us * 1e-6], rate_sps=80)[0])
        return src_inner["fn"](t_us)

    dev = PtyDevice(VirtualFirmware(4, source=source)).start()
    ft = Fingertip(dev.port, queue_size=100_000, name="virtual fingertip (host build)").open()

    def arm() -> tuple[float, float]:
        now_us = dev._device_us()
        start["us"] = now_us + int(LEAD_S * 1e6)
        src_inner["fn"] = sensor.as_source(scene, t0_us=start["us"], rate_sps=80)
        return time.monotonic() + LEAD_S, start["us"]

    return ft, arm, dev.stop, "the firmware's device logic built for the host"


def run_demo(out_dir: str | Path = "demo-output", *, use_firmware: bool | None = None,
             seed: int = 7, live: bool | None = None) -> DemoResult:
    """Run the demo; ``use_firmware`` None = simavr when built, else the host build."""
    t_run = time.monotonic()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    scene = demo_scene()
    duration = scene.duration_s + 0.5
    sensor = VirtualStrainSensor(seed, rate_sps=80)
    if use_firmware is None:
        from .sim.device.simavr import HarnessError, firmware_elf, harness_binary
        try:
            harness_binary()
            firmware_elf(4)
            use_firmware = True
        except HarnessError as e:
            log.warning("%s; using the firmware's host build instead", e)
            use_firmware = False
    live_line = _Live(sys.stderr.isatty() if live is None else live)
    print(f"simulating the audio of a {scene.duration_s:.1f} s scene ...", file=sys.stderr)
    vib = simulate(Script(scene.parts, gap_s=scene.gap_s, signals=("vibration",)), seed=seed)
    trace = vib.audio.samples.astype(np.float32)
    fs = float(vib.audio.fs)

    force_model, calibration = _calibrate(seed, out / "calibration")
    material = _material_model(seed, out / "material")

    make = _firmware_device if use_firmware else _python_device
    ft, arm, stop_device, what = make(sensor, scene, duration)
    print(f"virtual fingertip: {what} on {ft.port}", file=sys.stderr)
    frames: list[Frame] = []
    forces: list[np.ndarray] = []
    rec = Recorder(out / "demo.mcap", overwrite=True).start()
    try:
        offsets = ft.tare(samples=16)
        print("tared: offsets " + ", ".join(map(str, offsets)), file=sys.stderr)
        def on_frame(f: Frame) -> None:
            frames.append(f)
            forces.append(force_model.estimate(f.counts))

        ft.add_callback(on_frame)
        rec.attach(ft, "index", force_model=force_model)
        rec.write_info("index", ft.info)
        ft.start()
        host_start, scene_t0_us = arm()

        def piezo(t: np.ndarray) -> np.ndarray:
            k = np.clip((t * fs).astype(np.int64), 0, trace.size - 1)
            out = trace[k]
            out[t * fs >= trace.size] = 0.0
            return out

        # The sound card starts with the scene; its clock is the host's here.
        mic = SimulatedSource(piezo, fs, dtype="int16", realtime=True, duration=duration,
                              host_time0=host_start)
        chunks = []
        stop = threading.Event()

        def capture() -> None:
            for chunk in mic.chunks():
                chunks.append(chunk)
                rec.write_audio("index", chunk)
                if stop.is_set():
                    break

        while time.monotonic() < host_start:
            time.sleep(0.005)
        mic.start()
        cap = threading.Thread(target=capture, daemon=True)
        cap.start()
        t_end = host_start + duration
        label, rims, next_check = "-", 0, 0.0

        def played_s() -> float:
            """How much of the scene the device has played: it plays on the device's clock,
            and a device behind the wall clock (simavr on a busy host) is not done at t_end."""
            return (frames[-1].device_time_us - scene_t0_us) * 1e-6 if frames else 0.0

        def scene_played(now: float) -> bool:
            # Waited for up to one more scene length, never for ever.
            return now >= t_end and (played_s() >= duration or now >= t_end + duration)

        while not scene_played(time.monotonic()):
            time.sleep(0.05)
            now = time.monotonic()
            if chunks and now >= next_check:
                # Every half second: the material of the last 0.6 s, the rims so far.
                next_check = now + 0.5
                recent = np.concatenate([c.samples.reshape(-1) for c in chunks[-60:]])
                label = _live_material(material, to_float(recent[-int(0.6 * fs):]), fs)
                heard = to_float(np.concatenate([c.samples.reshape(-1) for c in chunks]))
                rims = sum(1 for e in vibration_onsets(heard, fs, t0=chunks[0].host_time)
                           if e.time - host_start > 9.0)  # during the cup slide
            if forces:
                fx, fy = forces[-1]
                live_line.show(f"t {now - host_start:5.1f} s  frames {len(frames):5d}  "
                               f"F = ({fx:+.2f}, {fy:+.2f}) N  |F| {np.hypot(fx, fy):.2f} N"
                               f"  material {label:<16s}  rims {rims}  "
                               f"lost {ft.stats.frames_lost}")
        live_line.done()
        if played_s() < duration:
            log.warning("the device ran behind the wall clock: it reached %.1f s of the "
                        "%.1f s scene", played_s(), duration)
        ft.stop()
        mic.stop()
        stop.set()
        cap.join(timeout=2)
        stats = {"frames": len(frames), "frames_lost": ft.stats.frames_lost,
                 "crc_errors": ft.stats.crc_errors,
                 "audio_frames": int(sum(c.frames for c in chunks)),
                 "audio_overflows": mic.stats.overruns_frames}
    except BaseException:
        rec.close()
        raise
    finally:
        ft.close()
        stop_device()

    # Events and the summary, on the scene's time axis (0 = scene start).
    scene_frames = [f for f in frames if f.host_time >= host_start - 0.2]
    t_force = np.array([f.host_time - host_start for f in scene_frames])
    counts = np.array([f.counts for f in scene_frames], dtype=np.float64)
    audio = to_float(np.concatenate([c.samples.reshape(-1) for c in chunks])).astype(np.float32)
    audio_t0 = chunks[0].host_time - host_start if chunks else 0.0
    events = contact_intervals(t_force, counts) + vibration_onsets(audio, fs, t0=audio_t0)
    events.sort(key=lambda e: e.time)
    # The events go into the recording too, on its host clock.
    rec.write_events("index", [Event(e.time + host_start, e.kind, e.value) for e in events])
    rec_stats = rec.close()
    stats["recording_messages"] = int(sum(rec_stats.written.values()))
    stats["recording_dropped"] = int(sum(rec_stats.dropped.values()))
    truth = rim_truth(scene)
    first = len(frames) - len(scene_frames)
    f_arr = np.array(forces[first:], dtype=np.float64).reshape(-1, 2)
    materials = _material_segments(material, audio, fs, audio_t0, events)
    png = session_summary(out / "demo_summary.png", force_t=t_force, counts=counts, audio=audio,
                          fs=fs, audio_t0=audio_t0, events=events, truth=truth,
                          forces=f_arr, labels=materials,
                          title=f"virtual fingertip demo, {what}: press; slide over coarse "
                                "fabric, copper tape; slide down a cup stack")
    return DemoResult(frames, audio, fs, events, png, out / "demo.mcap", what, stats=stats,
                      forces=f_arr, materials=materials, calibration=calibration,
                      seconds=time.monotonic() - t_run)


def _live_material(clf, x: np.ndarray, fs: float) -> str:
    """The material of a short stretch of audio, or "-" when nothing slides."""
    from .models.vibration.features import Recording

    try:
        preds = clf.classify(Recording(x.astype(np.float64), fs)).predictions
    except ValueError:
        return "-"
    loud = [p for p in preds if p.level_db > LOUD_DB]
    return loud[-1].label if loud else "-"


def _calibrate(seed: int, out: Path):
    """The paper's calibration sweep on this virtual unit, fitted and exported to ONNX; the
    model and what the calibration says of it."""
    from .models.force.calibrate import fit_calibration, from_arrays
    from .models.force.runtime import ForceModel

    sensor = VirtualStrainSensor(seed, rate_sps=80)
    # The unit at rest, averaged as `tare` does on the device, then the sweep.
    tare = sensor.counts_batch(np.zeros((16, 2)), 0.0, np.arange(1, 17) / 80).mean(axis=0)
    sw = calibration_sweep(sensor, seed=seed, t0_us=1_000_000)
    data = from_arrays(sw.counts - tare, sw.fx, sw.fy, angle_deg=sw.angle_deg,
                       height_mm=sw.height_mm, trial=sw.trial)
    rep = fit_calibration(data, out, models="affine,mlp16x16", epochs=300, plot=False)
    best = rep.chosen_result
    said = f"{rep.chosen}, held-out RMSE {best.rmse_n:.3f} N"
    print(f"calibrated: {said}", file=sys.stderr)
    return ForceModel(out / "force.onnx"), said


def _material_model(seed: int, out: Path):
    """A material classifier trained on simulated slides over the paper's seven materials."""
    from .models.vibration.classify import VibrationClassifier
    from .models.vibration.material import train_material
    from .sim.dataset import write_vibration

    write_vibration(out / "data", kind="materials", recordings_per_class=6, seconds=1.0,
                    seed=seed + 100, force=True)
    train_material(out / "data", out, plot=False, epochs=150)
    print("material classifier trained on 42 simulated slides", file=sys.stderr)
    return VibrationClassifier(out / "material.onnx")


def _material_segments(clf, audio: np.ndarray, fs: float, t0: float,
                       events: list[Event]) -> list[tuple[float, float, str]]:
    """The majority material of each contact that vibrated like a slide (not a press)."""
    from .models.vibration.features import Recording

    try:
        preds = clf.classify(Recording(audio.astype(np.float64), fs)).predictions
    except ValueError:
        return []
    makes = [e.time for e in events if e.kind == "contact_make"]
    breaks = [e.time for e in events if e.kind == "contact_break"]
    onsets = [e.time for e in events if e.kind == "vibration_onset"]
    out = []
    for m, b in zip(makes, breaks, strict=False):
        if sum(1 for o in onsets if m + 0.1 < o < b) >= 2:
            continue  # rims: a cup stack, not a material
        inside = [p for p in preds if m + 0.1 <= p.t_start + t0 and p.t_end + t0 <= b - 0.1]
        loud = [p for p in inside if p.level_db > LOUD_DB]
        if len(loud) < max(2, len(inside) // 2):
            continue
        names = [p.label for p in loud]
        out.append((m, b, max(set(names), key=names.count)))
    return out


def rim_truth(scene: Script) -> dict[str, list[float]]:
    """Ground-truth rim times of the cup slide on the script's time axis."""
    rims: list[float] = []
    for off, part in zip(scene.offsets_s, scene.parts, strict=True):
        if isinstance(part, CupStackSlide):
            rims += [float(off) + r for r in part.events()["rim_times_s"]]
    return {"rims": rims}
