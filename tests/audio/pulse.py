"""A private PulseAudio server with a null sink, for capture tests through the real stack.

The recipe of ../shared/NOTES.md: its own XDG_RUNTIME_DIR and HOME in a temporary directory,
anonymous auth on its unix socket, a null sink ``piezo`` at 44100 Hz mono, one ``parec``
reader kept running (otherwise the null sink renders in 2 s blocks), players started with
``paplay --device=piezo`` and killed by PID. Every process is started here and stopped here.
"""
from __future__ import annotations

import glob
import os
import select
import shutil
import signal
import subprocess
import tempfile
import time
from pathlib import Path

TOOLS = ("pulseaudio", "pactl", "parec", "paplay")
PACKAGES = "pulseaudio pulseaudio-utils libasound2-plugins libportaudio2"
ALSA_PULSE_PLUGIN = "libasound_module_pcm_pulse.so"


class PulseError(RuntimeError):
    pass


def check_tools(path: str | None = None) -> dict[str, str]:
    """The full path of each tool; PulseError naming the Debian packages when one is missing."""
    found = {t: shutil.which(t, path=path) for t in TOOLS}
    missing = [t for t, p in found.items() if p is None]
    if missing:
        raise PulseError(f"{', '.join(missing)} not found: the audio tests need the Debian "
                         f"packages {PACKAGES} (make setup installs them)")
    return found  # type: ignore[return-value]


def check_alsa_plugin(patterns: tuple[str, ...] = ("/usr/lib/*/alsa-lib", "/usr/lib/alsa-lib",
                                                   "/usr/lib64/alsa-lib")) -> None:
    """The ALSA pulse plugin that PortAudio's 'pulse' device goes through."""
    for pattern in patterns:
        for d in glob.glob(pattern):
            if os.path.exists(os.path.join(d, ALSA_PULSE_PLUGIN)):
                return
    raise PulseError(f"ALSA's pulse plugin ({ALSA_PULSE_PLUGIN}) not found: install the "
                     f"Debian package libasound2-plugins (the audio tests need {PACKAGES})")


def _stop(proc: subprocess.Popen, timeout: float = 5.0) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout)


class PulseServer:
    """Start with :meth:`start`, stop with :meth:`stop` (kills everything it started)."""

    def __init__(self, sink: str = "piezo", rate: int = 44100, channels: int = 1) -> None:
        self.tools = check_tools()
        check_alsa_plugin()
        self.sink = sink
        self.rate = rate
        self.channels = channels
        # Short path: a unix socket path must stay under 108 bytes.
        self.dir = Path(tempfile.mkdtemp(prefix="ft-pulse-"))
        self.socket = self.dir / "pulse" / "native"
        self.log_path = self.dir / "pulseaudio.log"
        self.client_conf = self.dir / "client.conf"
        # Clients must never autospawn a server of their own (it would outlive the tests).
        self.client_conf.write_text("autospawn = no\n", encoding="utf-8")
        self.env = dict(os.environ, XDG_RUNTIME_DIR=str(self.dir), HOME=str(self.dir),
                        **self.client_env())
        self.server: subprocess.Popen | None = None
        self.reader: subprocess.Popen | None = None
        self.players: list[subprocess.Popen] = []

    def client_env(self) -> dict[str, str]:
        """What a client process (this one: sounddevice) needs to find the server."""
        return {"PULSE_SERVER": f"unix:{self.socket}",
                "PULSE_CLIENTCONFIG": str(self.client_conf),
                "PULSE_COOKIE": str(self.dir / "cookie")}

    def _run(self, *args: str, timeout: float = 5.0) -> subprocess.CompletedProcess:
        return subprocess.run(list(args), env=self.env, capture_output=True, text=True,
                              timeout=timeout)

    def log_tail(self, n: int = 20) -> str:
        try:
            lines = self.log_path.read_text(errors="replace").splitlines()
        except OSError:
            return "(no server log)"
        return "\n".join(lines[-n:])

    def start(self, timeout: float = 15.0) -> PulseServer:
        with open(self.log_path, "wb") as log:
            self.server = subprocess.Popen(
                [self.tools["pulseaudio"], "-n", "--daemonize=no", "--exit-idle-time=-1",
                 "--disallow-exit", "--use-pid-file=no", "--log-target=stderr",
                 "-L", "module-native-protocol-unix auth-anonymous=1",
                 "-L", f"module-null-sink sink_name={self.sink} rate={self.rate} "
                       f"channels={self.channels}"],
                env=self.env, stdin=subprocess.DEVNULL, stdout=log, stderr=log)
        deadline = time.monotonic() + timeout
        while True:
            if self.server.poll() is not None:
                raise PulseError(f"pulseaudio exited with {self.server.returncode}:\n"
                                 f"{self.log_tail()}")
            if self._run("pactl", "info").returncode == 0:
                break
            if time.monotonic() > deadline:
                raise PulseError(f"pulseaudio did not answer pactl info in {timeout} s:\n"
                                 f"{self.log_tail()}")
            time.sleep(0.05)
        res = self._run("pactl", "set-default-source", f"{self.sink}.monitor")
        if res.returncode != 0:
            raise PulseError(f"pactl set-default-source failed: {res.stderr.strip()}")
        self.reader = subprocess.Popen(
            [self.tools["parec"], "--latency-msec=10", "-d", f"{self.sink}.monitor"],
            env=self.env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL)
        self.wait_rendering(deadline - time.monotonic())
        return self

    def wait_rendering(self, timeout: float) -> float:
        """Wait until the sink's monitor delivers audio; returns how long that took.

        A fresh null sink delivers nothing for its first 1.5-2 s (one 2 s render block);
        a stream opened meanwhile gets no callbacks and drops the first frames played.
        """
        t0 = time.monotonic()
        probe = subprocess.Popen(
            [self.tools["parec"], "--latency-msec=10", "-d", f"{self.sink}.monitor"],
            env=self.env, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL)
        try:
            assert probe.stdout is not None
            ready, _, _ = select.select([probe.stdout], [], [], max(timeout, 0.1))
            if not ready or not os.read(probe.stdout.fileno(), 4096):
                raise PulseError(f"the null sink's monitor delivered no audio in {timeout:.1f} s:"
                                 f"\n{self.log_tail()}")
        finally:
            _stop(probe)
            if probe.stdout is not None:
                probe.stdout.close()
        return time.monotonic() - t0

    def play(self, path: str | os.PathLike) -> subprocess.Popen:
        """Start ``paplay --device=<sink> path``; stopped by :meth:`stop` if still running."""
        p = subprocess.Popen([self.tools["paplay"], f"--device={self.sink}", str(path)],
                             env=self.env, stdin=subprocess.DEVNULL,
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        self.players.append(p)
        return p

    def pids(self) -> list[int]:
        procs = [self.server, self.reader, *self.players]
        return [p.pid for p in procs if p is not None]

    def alive(self) -> list[int]:
        procs = [self.server, self.reader, *self.players]
        return [p.pid for p in procs if p is not None and p.poll() is None]

    def stop(self) -> None:
        """Stop players, the reader, then the server, each by its PID; remove the directory."""
        for p in self.players:
            _stop(p)
            if p.stderr is not None:
                p.stderr.close()
        if self.reader is not None:
            _stop(self.reader)
        if self.server is not None:
            _stop(self.server)
        shutil.rmtree(self.dir, ignore_errors=True)
