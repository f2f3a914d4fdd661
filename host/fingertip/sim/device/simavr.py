"""The real firmware in simavr: a controller for ``firmware/sim/build/fingertip-sim``.

The harness runs the Uno firmware ELF with simulated HX711s and puts its UART on a private
pty; this class starts it, speaks its line-based control protocol (firmware/sim/README.md)
and hands out the pty path, so that :class:`fingertip.Fingertip` talks to the real firmware
exactly as it would to a board on USB.
"""
from __future__ import annotations

import json
import logging
import os
import queue
import subprocess
import threading
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

log = logging.getLogger(__name__)

REPO = Path(__file__).resolve().parents[4]
HARNESS = REPO / "firmware" / "sim" / "build" / "fingertip-sim"
ELF = {
    4: REPO / "firmware" / "build" / "fw4" / "fingertip.elf",
    16: REPO / "firmware" / "build" / "fw16" / "fingertip.elf",
    "digitalread": REPO / "firmware" / "build" / "fw4-digitalread" / "fingertip.elf",
}


class HarnessError(RuntimeError):
    """The harness is missing, failed to start, or refused a command."""


def firmware_elf(build: int | str = 4) -> Path:
    """Path of a built firmware (``4``, ``16`` or ``"digitalread"``); FINGERTIP_ELF overrides."""
    env = os.environ.get("FINGERTIP_ELF")
    path = Path(env) if env else ELF[build]
    if not path.exists():
        raise HarnessError(f"no firmware at {path}: build it with `make firmware`")
    return path


def harness_binary() -> Path:
    path = Path(os.environ.get("FINGERTIP_SIM", HARNESS))
    if not path.exists():
        raise HarnessError(f"no simavr harness at {path}: build it with `make sim`")
    return path


class FirmwareSim:
    """One harness process. Starts held: open the pty, then call :meth:`go`.

    >>> with FirmwareSim(channels=4) as sim:                # doctest: +SKIP
    ...     sim.set(0, 123456)
    ...     port = sim.pty             # open it (pyserial flushes input on open) ...
    ...     sim.go()                   # ... then let the firmware boot
    """

    def __init__(self, channels: int = 4, elf: str | Path | None = None, *,
                 throttle: float | None = None, noise: float = 0.0, seed: int = 1,
                 link: str | Path | None = None, extra_args: Sequence[str] = ()) -> None:
        self.channels = channels
        self.boot_us = 0.0
        """Simulated time of the last reset: the firmware's clock (its frames' stamps) reads
        the simulated time since then."""
        self.elf = Path(elf) if elf else firmware_elf(channels)
        args = [str(harness_binary()), "-n", str(channels), "--seed", str(seed)]
        if throttle is not None:
            args += ["--throttle", str(throttle)]
        if noise:
            args += ["--noise", str(noise)]
        if link:
            args += ["--link", str(link)]
        args += [*extra_args, str(self.elf)]
        self._args = args
        self._proc: subprocess.Popen[str] | None = None
        self._replies: queue.Queue[dict[str, Any]] = queue.Queue()
        self.events: list[dict[str, Any]] = []
        self.exit_stats: dict[str, Any] | None = None
        self._lock = threading.Lock()
        self.hello: dict[str, Any] = {}
        self.pty = ""

    # --- life cycle -----------------------------------------------------------------------

    def start(self) -> FirmwareSim:
        self._proc = subprocess.Popen(self._args, stdin=subprocess.PIPE,
                                      stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                      text=True, bufsize=1)
        line = self._proc.stdout.readline()  # type: ignore[union-attr]
        if not line:
            err = self._proc.stderr.read() if self._proc.stderr else ""  # type: ignore
            self._proc.wait(timeout=5)
            raise HarnessError(f"the harness did not start ({' '.join(self._args)}): {err}")
        self.hello = json.loads(line)
        self.pty = self.hello["pty"]
        threading.Thread(target=self._pump_stdout, daemon=True, name="sim-stdout").start()
        threading.Thread(target=self._pump_stderr, daemon=True, name="sim-stderr").start()
        return self

    def _pump_stdout(self) -> None:
        assert self._proc and self._proc.stdout
        for line in self._proc.stdout:
            try:
                msg = json.loads(line)
            except json.JSONDecodeError:
                log.warning("harness: unparsable line %r", line)
                continue
            if "event" in msg:
                self.events.append(msg)
                if msg["event"] == "exit":
                    self.exit_stats = msg.get("stats")
                continue
            self._replies.put(msg)

    def _pump_stderr(self) -> None:
        assert self._proc and self._proc.stderr
        for line in self._proc.stderr:
            log.debug("harness: %s", line.rstrip())

    def close(self) -> dict[str, Any] | None:
        """Quit the harness; returns its final stats (also in :attr:`exit_stats`)."""
        proc = self._proc
        if proc is None:
            return self.exit_stats
        if proc.poll() is None:
            try:
                self.command("quit", timeout=10)
            except (HarnessError, BrokenPipeError, OSError):
                pass
            try:
                if proc.stdin:
                    proc.stdin.close()
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(timeout=5)
        self._proc = None
        return self.exit_stats

    def __enter__(self) -> FirmwareSim:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def running(self) -> bool:
        return self._proc is not None and self._proc.poll() is None

    # --- commands -------------------------------------------------------------------------

    def command(self, line: str, timeout: float = 60.0) -> dict[str, Any]:
        """Send one control line and wait for its reply; raise on ``ok: false``."""
        with self._lock:
            reply = self._send_and_wait(line, timeout)
        if not reply.get("ok", False):
            raise HarnessError(f"harness refused {line!r}: {reply.get('error')}")
        return reply

    def _send_and_wait(self, line: str, timeout: float) -> dict[str, Any]:
        proc = self._proc
        if proc is None or proc.stdin is None or proc.poll() is not None:
            raise HarnessError("the harness is not running")
        proc.stdin.write(line + "\n")
        proc.stdin.flush()
        try:
            return self._replies.get(timeout=timeout)
        except queue.Empty:
            raise HarnessError(f"no reply to {line!r} within {timeout} s") from None

    def send_many(self, lines: Iterable[str]) -> None:
        """Send many commands at once (e.g. timed values), then check every reply."""
        with self._lock:
            proc = self._proc
            if proc is None or proc.stdin is None:
                raise HarnessError("the harness is not running")
            lines = list(lines)
            proc.stdin.write("".join(x + "\n" for x in lines))
            proc.stdin.flush()
            for line in lines:
                reply = self._replies.get(timeout=60)
                if not reply.get("ok", False):
                    raise HarnessError(f"harness refused {line!r}: {reply.get('error')}")

    def go(self) -> None:
        self.command("go")

    def hold(self) -> None:
        self.command("hold")

    def set(self, channel: int | str, value: int) -> None:
        self.command(f"set {channel} {int(value)}")

    def at(self, t_us: float, channel: int | str, value: int) -> None:
        self.command(f"at {t_us:.4f} {channel} {int(value)}")

    def rows(self, times_us: Sequence[float], values: Sequence[Sequence[int]]) -> None:
        """Schedule per-channel values (counts at gain 128) at exact simulated times."""
        self.send_many(f"row {t:.4f} " + " ".join(str(int(v)) for v in row)
                       for t, row in zip(times_us, values, strict=True))

    def chip(self, channel: int | str, mode: str) -> None:
        """``ok``, ``absent`` (DOUT high forever) or ``stuck_low``."""
        self.command(f"chip {channel} {mode}")

    def noise(self, channel: int | str, sigma: float) -> None:
        self.command(f"noise {channel} {sigma}")

    def clock_ppm(self, channel: int | str, ppm: float) -> None:
        self.command(f"clock {channel} {ppm}")

    def until(self, t_us: float, timeout: float = 600.0) -> dict[str, Any]:
        """Run to a simulated time and hold there (the reply waits for it)."""
        return self.command(f"until {t_us:.4f}", timeout=timeout)

    def step(self, us: float, timeout: float = 600.0) -> dict[str, Any]:
        return self.command(f"step {us:.4f}", timeout=timeout)

    def time_us(self) -> float:
        return float(self.command("time")["t_us"])

    def reset(self) -> None:
        """A reset of the MCU (as the reset button or a DTR pulse does)."""
        self.command("reset")
        self.boot_us = self.time_us()

    def throttle(self, factor: float | None) -> None:
        self.command(f"throttle {'off' if factor is None else factor}")

    def stats(self) -> dict[str, Any]:
        return self.command("stats")["stats"]

    def stats_reset(self) -> None:
        self.command("stats_reset")

    def chips(self) -> list[dict[str, Any]]:
        return self.command("chips")["chips"]


def open_fingertip(sim: FirmwareSim, port: str | Path | None = None, **kwargs: Any):
    """A :class:`fingertip.Fingertip` on the harness's pty (or ``port``, e.g. its ``link``),
    opened before the firmware boots (pyserial's open() flushes input, which would eat the
    boot message)."""
    from ...device import Fingertip  # the device layer sits above sim: import at use
    from ...transport import open_serial

    started = False

    def factory(port: str):
        nonlocal started
        stream = open_serial(port)
        if not started:
            started = True
            sim.go()
        return stream

    return Fingertip(str(port or sim.pty), open_stream=factory, **kwargs).open()
