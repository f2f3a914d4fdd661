"""Soak: a four-finger hand of virtual fingertips for minutes to hours, devices killed and
restarted, everything recorded; frames lost, reconnect times, memory growth, file integrity.

Four ``fingertip sim device`` processes (the firmware's twin, each on its own pty behind a
stable link) stream at 80 Hz; the host opens them as a :class:`~fingertip.Hand`, runs a force
model (ONNX, fitted here on a simulated calibration sweep) on every frame, feeds four
simulated 44.1 kHz microphones, detects contact and vibration events every second, and
records frames, forces, audio and events into one MCAP file. Every ``kill_every`` seconds
one device process (in turn) is killed with SIGKILL and started again after ``OUTAGE_S``.

Figures: ``soak_frames_lost`` (frames missing while connected: sequence gaps, queue
overruns, and frames the recording dropped; the outages are counted apart in
``soak_outage_frames``, the bridge's own count, and ``soak_device_resets``),
``soak_reconnect_max_s`` (from a restarted device's pty being ready to its first frame at
the host), ``soak_rss_growth_pct`` (resident memory at the end against
after the warm-up), ``soak_file_ok`` (the recording is complete and every message the
recorder wrote reads back through the ``mcap`` package's indexed reader) and
``soak_minutes``. ``make soak`` (SOAK_MINUTES=30) or ``python tests/bench/bench_soak.py
--minutes M`` runs it; it is not part of ``make test`` or the default ``make bench``.
"""
from __future__ import annotations

import argparse
import os
import select
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from pathlib import Path

import numpy as np

MINUTES = float(os.environ.get("SOAK_MINUTES", "30"))
FINGERS = ("thumb", "index", "middle", "ring")
RATE = 80
STEP_US = 1_000_000 // RATE
OUTAGE_S = 1.0
"""Seconds a killed device stays away before it is started again."""

DESCRIPTION = {
    "soak_minutes": ("minutes the soak ran", None),
    "soak_frames_lost": ("frames lost while connected (4 fingers at 80 Hz; outages apart)",
                         ("<=", 0)),
    "soak_outage_frames": ("frames missing across the outages of killed devices (the "
                           "bridge's outage_frames)", None),
    "soak_outage_frames_seen": ("the same, from the callbacks' arrival times (a check)", None),
    "soak_device_resets": ("device restarts the bridge counted (one per kill)", None),
    "soak_link_seq_lost": ("device messages of any kind missing by sequence number while "
                           "connected (the bridge's frames_lost less its outage_frames)",
                           None),
    "soak_kills": ("device processes killed with SIGKILL and restarted", None),
    "soak_reconnect_max_s": ("slowest reconnect: restarted pty ready -> first frame", ("<=", 1)),
    "soak_rss_growth_pct": ("resident memory growth, end against after the warm-up, %",
                            ("<=", 5)),
    "soak_file_ok": ("the recording is complete and reads back whole (1 = yes)", (">=", 1)),
    "soak_messages": ("messages in the recording", None),
}


def rss_kb() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    return 0


class DeviceProcess:
    """One ``fingertip sim device`` process on a stable link."""

    def __init__(self, link: Path, seed: int) -> None:
        self.link, self.seed = link, seed
        self.proc: subprocess.Popen | None = None

    def start(self, timeout: float = 30.0) -> float:
        """Start it; the monotonic time its link appeared (its pty is ready from then)."""
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "fingertip.cli", "sim", "device", "--link", str(self.link),
             "--seed", str(self.seed)], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + timeout
        while not self.link.exists() and time.monotonic() < deadline:
            time.sleep(0.002)
        t_ready = time.monotonic()
        buf = b""
        while time.monotonic() < deadline and b"\n" not in buf:
            r, _, _ = select.select([self.proc.stdout], [], [], 0.1)
            if r:
                c = os.read(self.proc.stdout.fileno(), 256)
                if not c:
                    break
                buf += c
        if b"virtual fingertip on" not in buf:
            raise RuntimeError(f"sim device did not start: {buf!r}")
        return t_ready

    def kill(self) -> None:
        """SIGKILL, and remove its link as udev removes a by-id link on unplug: a stale
        link to a freed pty number could lead to whatever pty takes that number next."""
        if self.proc is not None and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGKILL)
            self.proc.wait(10)
        self.link.unlink(missing_ok=True)
        if self.proc is not None and self.proc.stdout:
            self.proc.stdout.close()

    def stop(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        if self.proc is not None and self.proc.stdout:
            self.proc.stdout.close()


class FingerWatch:
    """Continuity of one finger's frames: gaps inside a connection, and where each
    connection began and ended (device time restarts with a restarted device)."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.frames = 0
        self.gaps = 0
        self.last_dev: int | None = None
        self.last_arrival = 0.0
        self.first_after: dict[int, float] = {}  # kill index -> first frame arrival after it
        self.epoch_kill: int | None = None  # set by the killer: the next new epoch answers it
        self.window: list[tuple[float, tuple[int, ...]]] = []  # (host_time, counts)

    def on_frame(self, frame) -> None:
        with self.lock:
            self.frames += 1
            d = frame.device_time_us
            if self.last_dev is not None and d > self.last_dev:
                steps = round((d - self.last_dev) / STEP_US)
                if steps > 1:
                    self.gaps += steps - 1
            elif self.last_dev is not None and self.epoch_kill is not None:
                self.first_after.setdefault(self.epoch_kill, frame.arrival_time)
                self.epoch_kill = None
            self.last_dev = d
            self.last_arrival = frame.arrival_time
            self.window.append((frame.host_time, frame.counts))


def _force_model(folder: Path):
    from fingertip.models.force.calibrate import fit_affine, from_arrays, model_metadata
    from fingertip.models.force.runtime import ForceModel
    from fingertip.sim.physics import VirtualStrainSensor
    from fingertip.sim.device.calibration_rig import calibration_sweep

    s = VirtualStrainSensor(0)
    sw = calibration_sweep(s, seed=1, angles_deg=(-40, 0, 40), heights_mm=(1, 3))
    data = from_arrays(sw.counts, sw.fx, sw.fy, angle_deg=sw.angle_deg,
                       height_mm=sw.height_mm, trial=sw.trial)
    m = fit_affine(data.counts, data.force)
    path = folder / "force.onnx"
    m.to_onnx(path, model_metadata(m, data, data))
    return ForceModel(path)


def _tapping(seed: int):
    """A microphone signal: noise and a short ring every 0.7 s (vibration events)."""
    rng = np.random.default_rng(seed)
    noise = rng.normal(0, 0.01, 44100).astype(np.float64)

    def func(t: np.ndarray) -> np.ndarray:
        ph = np.mod(t, 0.7)
        ring = 0.5 * np.exp(-ph / 0.01) * np.sin(2 * np.pi * 2500 * t)
        return noise[(t * 44100).astype(np.int64) % len(noise)] + ring

    return func


def soak(minutes: float, workdir: Path) -> dict[str, float]:
    from mcap.reader import make_reader

    from fingertip import Fingertip
    from fingertip.audio import SimulatedSource
    from fingertip.device import Hand
    from fingertip.events.detect import Event, contact_intervals, vibration_onsets
    from fingertip.record import Recorder, Recording

    total_s = minutes * 60
    kill_every = min(180.0, max(15.0, total_s / 6))
    warmup_s = min(60.0, max(10.0, total_s / 10))
    model = _force_model(workdir)
    devices = {f: DeviceProcess(workdir / f"tty_{f}", k) for k, f in enumerate(FINGERS)}
    for d in devices.values():
        d.start()
    hand = Hand({f: Fingertip(str(devices[f].link), name=f) for f in FINGERS})
    watches = {f: FingerWatch() for f in FINGERS}
    rec = Recorder(workdir / "soak.mcap", flush_interval=0.5)
    outage_frames = 0
    reconnect_s: list[float] = []
    kills: list[tuple[str, float, float, float]] = []  # finger, t_kill, t_ready, last arrival
    events = 0
    sources = {}
    stop = threading.Event()
    try:
        hand.open()
        rec.start()
        for f in FINGERS:
            dev = hand.device(f)
            rec.attach(dev, f, force_model=model)

            dev.add_callback(watches[f].on_frame)
        audio_tail: dict[str, list[np.ndarray]] = {f: [] for f in FINGERS}

        def pump(f: str, src) -> None:  # the recorder's audio, and a tap for the events
            while not stop.is_set():
                c = src.read(4410, timeout=0.1)
                if c is None:
                    continue
                rec.write_audio(f, c)
                with watches[f].lock:
                    audio_tail[f].append(c.samples[:, 0])
                    del audio_tail[f][:-10]

        for k, f in enumerate(FINGERS):
            src = SimulatedSource(_tapping(k), 44100, dtype="int16", blocksize=441,
                                  name=f"mic {f}")
            sources[f] = src
            src.start()
            threading.Thread(target=pump, args=(f, src), daemon=True).start()
        hand.start()

        def detect() -> None:  # the events layer on the live signals, once a second
            nonlocal events
            while not stop.wait(1.0):
                for f, w in watches.items():
                    with w.lock:
                        win, w.window = w.window[-2 * RATE:], w.window[-2 * RATE:]
                    if len(win) > 20:
                        t = np.array([a for a, _ in win])
                        x = np.array([b for _, b in win], dtype=np.float64)
                        ev = contact_intervals(t, x)
                        events += rec.write_events(f, ev)
                    with w.lock:
                        tail = list(audio_tail[f])
                    if tail:
                        x = np.concatenate(tail).astype(np.float64) / 32768.0
                        t_end = time.monotonic()
                        ev = vibration_onsets(x, 44100)  # times from the tail's start
                        events += rec.write_events(f, [
                            Event(t_end - len(x) / 44100 + e.time, e.kind, e.value)
                            for e in ev])

        det = threading.Thread(target=detect, daemon=True)
        det.start()
        t0 = time.monotonic()
        rss0 = None
        rss_minutes: list[int] = []  # MB once a minute: a leak climbs, a warm-up levels off
        next_kill = t0 + kill_every
        k = 0
        hand_frames = 0
        while (now := time.monotonic()) < t0 + total_s:
            if rss0 is None and now - t0 >= warmup_s:
                rss0 = rss_kb()
            if now - t0 >= 60 * len(rss_minutes):
                rss_minutes.append(rss_kb() // 1024)
            if now >= next_kill and now + 20 < t0 + total_s:
                f = FINGERS[k % len(FINGERS)]
                w = watches[f]
                with w.lock:
                    w.epoch_kill = k
                devices[f].kill()
                t_kill = time.monotonic()
                time.sleep(OUTAGE_S)
                t_ready = devices[f].start()
                kills.append((f, t_kill, t_ready, w.last_arrival))
                rec.write_event(f, "device_killed", float(k))
                k += 1
                next_kill = time.monotonic() + kill_every
            time.sleep(0.2)
            # The user's side: a control loop reads the hand's frames (and nothing is left
            # queued on the devices, whose own queues a Hand user never reads).
            while hand.read(timeout=0) is not None:
                hand_frames += 1
            for f in FINGERS:
                hand.device(f).drain()
        time.sleep(2.0)  # the last reconnect, if any, has time to finish
        rss1 = rss_kb()
        stop.set()
        det.join(5)
        for i, (f, _t_kill, t_ready, last) in enumerate(kills):
            first = watches[f].first_after.get(i)
            if first is None:
                reconnect_s.append(float("inf"))
                continue
            reconnect_s.append(first - t_ready)
            outage_frames += max(0, round((first - last) * RATE) - 1)
        try:
            hand.stop()
        except Exception:  # noqa: BLE001 - a device mid-reconnect at the very end
            pass
        stats = {f: hand.device(f).stats for f in FINGERS}
    finally:
        stop.set()
        for s in sources.values():
            s.stop()
        rs = rec.close()
        hand.close()
        for d in devices.values():
            d.stop()

    dropped_raw = sum(n for t, n in rs.dropped.items() if t.endswith("/raw"))
    # Sample frames missing between two received ones of one connection (the device time
    # advances 12.5 ms a frame), frames the hand's queue or the recording dropped, and
    # frames the callbacks saw that the file does not hold.
    gaps = sum(w.gaps for w in watches.values())
    seen = sum(w.frames for w in watches.values())
    written = Counter(rs.written)
    with open(workdir / "soak.mcap", "rb") as fh:
        read = Counter(ch.topic for _, ch, _ in make_reader(fh).iter_messages())
    r = Recording(workdir / "soak.mcap")
    file_ok = int(r.complete and read == written and not rs.dropped_total)
    raw_frames = sum(v for t, v in read.items() if t.endswith("/raw"))
    link = {k: sum(getattr(s, k) for s in stats.values())
            for k in ("frames_lost", "outage_frames", "seq_gaps", "crc_errors", "cobs_errors",
                      "overruns", "reconnects", "device_resets")}
    print(f"soak: {minutes:g} min, {raw_frames} frames recorded, {len(kills)} kills, "
          f"events {events}, reconnects {[round(x, 3) for x in reconnect_s]}, RSS "
          f"{rss0} -> {rss1} kB (MB a minute: {rss_minutes}), sample gaps {gaps}, "
          f"hand overruns {hand.overruns}, "
          f"recorder dropped {dict(rs.dropped)}, frames seen {seen} recorded {raw_frames}, "
          f"link {link}", file=sys.stderr)
    return {
        "soak_minutes": round(minutes, 2),
        "soak_frames_lost": gaps + hand.overruns + dropped_raw + abs(seen - raw_frames),
        "soak_link_seq_lost": link["frames_lost"] - link["outage_frames"],
        "soak_outage_frames": link["outage_frames"],
        "soak_outage_frames_seen": outage_frames,
        "soak_device_resets": link["device_resets"],
        "soak_kills": len(kills),
        "soak_reconnect_max_s": round(max(reconnect_s), 3) if reconnect_s else 0.0,
        "soak_rss_growth_pct": round(100 * (rss1 - rss0) / rss0, 2) if rss0 else float("nan"),
        "soak_file_ok": file_ok,
        "soak_messages": sum(read.values()),
    }


def run() -> dict[str, float]:
    with tempfile.TemporaryDirectory(prefix="fingertip-soak-") as d:
        return soak(MINUTES, Path(d))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=MINUTES, help="how long (default 30)")
    args = ap.parse_args()
    if not args.minutes > 0:
        ap.error("--minutes must be positive")
    os.environ["SOAK_MINUTES"] = repr(args.minutes)
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    from tests.bench import run as bench_run

    sys.argv = [sys.argv[0], "soak"]
    return bench_run.main()


if __name__ == "__main__":
    sys.exit(main())
