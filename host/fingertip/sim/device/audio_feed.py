"""Play a virtual audio trace into a PulseAudio sink: the real capture path, end to end.

The simulator's contact-microphone samples (float32, 1.0 = the sound card's full scale) are
written to a temporary WAV file and played with ``paplay --device=SINK`` (or piped from a
raw file into ``pacat --playback``). Whatever records the sink's monitor (for example
``fingertip.audio.SoundDeviceSource(device='pulse')`` with the monitor as default source)
then sees the virtual fingertip as it would see a USB sound card.

Samples that sit exactly on the 16-bit grid (what :func:`~fingertip.sim.physics.simulate`
produces: the card's 16-bit quantisation) are written as 16-bit PCM, so a 16-bit sink at the
same rate passes them through bit-exact; anything else is written as 32-bit float and
PulseAudio converts it (and resamples it, if the rates differ).

One player process per :class:`AudioFeed`, started by :meth:`~AudioFeed.start` and
stopped by PID (SIGTERM, then SIGKILL) in :meth:`~AudioFeed.stop`: never a loop in a
subshell, nothing left behind. PulseAudio's tools come from the Debian package
pulseaudio-utils. This module imports numpy, soundfile and the standard library only.
"""
from __future__ import annotations

import os
import shutil
import signal
import subprocess
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from ...audio.pcm import to_pcm

PLAYERS = ("paplay", "pacat")
PACKAGE = "pulseaudio-utils"


class AudioFeedError(RuntimeError):
    """The player is missing, could not start, or failed (its stderr is in the message)."""


def on_16bit_grid(x: np.ndarray) -> bool:
    """True if every sample is k / 32768 for an integer k in [-32768, 32767]."""
    x = np.asarray(x)
    if x.dtype == np.int16:
        return True
    if not np.issubdtype(x.dtype, np.floating):
        return False
    s = x.astype(np.float64) * 32768.0
    return bool(np.all(s == np.rint(s)) and s.min(initial=0) >= -32768
                and s.max(initial=0) <= 32767)


class AudioFeed:
    """Play ``samples`` (or an :class:`~fingertip.sim.physics.AudioTrace`) into ``sink``.

    ``samples``: float (1.0 = full scale) or int16, shape (n,) or (n, channels). ``fs``:
    the sample rate (taken from a trace when one is given). ``sink``: a PulseAudio sink name
    (``None``: the server's default sink). ``player``: ``"paplay"`` (a WAV file) or
    ``"pacat"`` (raw samples on its standard input). ``env``: the environment of the player
    (default: this process's, so ``PULSE_SERVER`` and friends apply). ``latency_msec``:
    passed to the player. ``lead_in_s``: silence played before the samples (PulseAudio
    may lose the first milliseconds of a new stream: seen here, the first 70 samples came
    back as zeros). Use as a context manager, or :meth:`start` / :meth:`wait` /
    :meth:`stop`.
    """

    def __init__(self, samples: Any, fs: float | None = None, sink: str | None = None, *,
                 player: str = "paplay", env: dict[str, str] | None = None,
                 latency_msec: int | None = None, lead_in_s: float = 0.1) -> None:
        if hasattr(samples, "samples") and hasattr(samples, "fs"):  # an AudioTrace
            fs = samples.fs if fs is None else fs
            samples = samples.samples
        if fs is None:
            raise ValueError("fs (the sample rate) is required for raw samples")
        if player not in PLAYERS:
            raise ValueError(f"player must be one of {PLAYERS}, not {player!r}")
        x = np.asarray(samples)
        if x.ndim == 1:
            x = x[:, None]
        if x.ndim != 2 or x.shape[1] < 1 or len(x) == 0:
            raise ValueError(f"samples must be (n,) or (n, channels) with n > 0, not {x.shape}")
        if not (x.dtype == np.int16 or np.issubdtype(x.dtype, np.floating)):
            raise ValueError(f"samples must be float or int16, not {x.dtype}")
        if np.issubdtype(x.dtype, np.floating) and not np.all(np.isfinite(x)):
            raise ValueError("samples hold NaN or Inf")
        self.fs = int(round(float(fs)))
        if not 1000 <= self.fs <= 384_000:
            raise ValueError(f"sample rate {fs} Hz is out of range")
        if not 0 <= lead_in_s <= 10:
            raise ValueError(f"lead_in_s must be between 0 and 10 s, not {lead_in_s}")
        self.lead_in_frames = int(round(lead_in_s * self.fs))
        """Frames of silence before sample 0 of ``samples``."""
        self.exact16 = on_16bit_grid(x)
        """True: written as 16-bit PCM, bit-exact through a 16-bit sink at the same rate."""
        if self.exact16:
            self._data = x if x.dtype == np.int16 else to_pcm(x, "int16")
        else:
            self._data = np.clip(x, -1.0, 1.0).astype(np.float32)
        if self.lead_in_frames:
            self._data = np.concatenate(
                [np.zeros((self.lead_in_frames, x.shape[1]), self._data.dtype), self._data])
        self.sink = sink
        self.player = player
        self.env = env
        self.latency_msec = latency_msec
        self.proc: subprocess.Popen | None = None
        self._dir: Path | None = None
        self._stdin = None
        self._error = b""

    # --- properties -----------------------------------------------------------------------

    @property
    def frames(self) -> int:
        """Frames played, lead-in included."""
        return len(self._data)

    @property
    def channels(self) -> int:
        return self._data.shape[1]

    @property
    def duration_s(self) -> float:
        return self.frames / self.fs

    @property
    def pid(self) -> int | None:
        return self.proc.pid if self.proc is not None else None

    @property
    def running(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    @property
    def returncode(self) -> int | None:
        return self.proc.poll() if self.proc is not None else None

    @property
    def trace_file(self) -> Path | None:
        """The temporary file the player reads, while there is one (removed by :meth:`stop`
        and by a failed :meth:`start`)."""
        if self._dir is None:
            return None
        return next(self._dir.glob("trace.*"), None)

    # --- life cycle -----------------------------------------------------------------------

    def _tool(self) -> str:
        path = (self.env or os.environ).get("PATH")
        exe = shutil.which(self.player, path=path)
        if exe is None:
            raise AudioFeedError(f"{self.player} not found: install the Debian package "
                                 f"{PACKAGE} (PulseAudio's command-line tools)")
        return exe

    def command(self, path: str) -> list[str]:
        """The player's command line for the file at ``path``."""
        argv = [self._tool()]
        if self.sink:
            argv.append(f"--device={self.sink}")
        if self.latency_msec is not None:
            argv.append(f"--latency-msec={int(self.latency_msec)}")
        if self.player == "paplay":
            return [*argv, path]
        fmt = "s16le" if self.exact16 else "float32le"
        return [*argv, "--playback", "--raw", f"--format={fmt}", f"--rate={self.fs}",
                f"--channels={self.channels}"]

    def start(self) -> AudioFeed:
        """Write the samples to a temporary file and start the player (returns at once)."""
        if self.proc is not None:
            raise AudioFeedError("this feed was already started (make a new AudioFeed)")
        self._dir = Path(tempfile.mkdtemp(prefix="ft-feed-"))
        try:
            if self.player == "paplay":
                import soundfile as sf

                path = self._dir / "trace.wav"
                sf.write(str(path), self._data, self.fs,
                         subtype="PCM_16" if self.exact16 else "FLOAT", format="WAV")
            else:
                path = self._dir / "trace.raw"
                self._data.astype(self._data.dtype.newbyteorder("<"), copy=False).tofile(path)
            argv = self.command(str(path))
            if self.player == "pacat":
                self._stdin = open(path, "rb")
            self.proc = subprocess.Popen(
                argv, env=self.env, stdin=self._stdin or subprocess.DEVNULL,
                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        except BaseException:
            self._cleanup()
            raise
        return self

    def wait(self, timeout: float | None = None) -> bool:
        """Wait until the player has played everything. True when it finished, False if it
        is still playing after ``timeout`` s; AudioFeedError if it failed."""
        if self.proc is None:
            raise AudioFeedError("not started")
        try:
            self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            return False
        self._collect()
        if self.proc.returncode != 0:
            err = self._error.decode(errors="replace").strip() or "(no message)"
            raise AudioFeedError(f"{self.player} exited with {self.proc.returncode} "
                                 f"(sink {self.sink or 'default'}): {err}")
        return True

    def stop(self, timeout: float = 5.0) -> None:
        """Stop the player if it still plays (SIGTERM to its PID, SIGKILL after ``timeout``
        s), and remove the temporary file. Safe to call more than once."""
        p = self.proc
        if p is not None and p.poll() is None:
            p.send_signal(signal.SIGTERM)
            try:
                p.wait(timeout)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait(timeout)
        self._collect()
        self._cleanup()

    def _collect(self) -> None:
        p = self.proc
        if p is not None and p.stderr is not None and not p.stderr.closed \
                and p.poll() is not None:
            try:
                self._error += p.stderr.read() or b""
            finally:
                p.stderr.close()
        if p is not None and p.poll() is not None:
            self._cleanup()

    def _cleanup(self) -> None:
        if self._stdin is not None:
            self._stdin.close()
            self._stdin = None
        if self._dir is not None:
            shutil.rmtree(self._dir, ignore_errors=True)
            self._dir = None

    def __enter__(self) -> AudioFeed:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def __del__(self) -> None:  # a forgotten feed must not leave a player behind
        try:
            self.stop(timeout=1.0)
        except Exception:
            pass


def play(samples: Any, fs: float | None = None, sink: str | None = None,
         timeout: float | None = None, **kw: Any) -> None:
    """Play and wait until done (AudioFeedError on failure; the player is stopped if
    ``timeout`` s pass first)."""
    feed = AudioFeed(samples, fs, sink, **kw).start()
    try:
        if not feed.wait(timeout if timeout is not None else feed.duration_s + 10.0):
            raise AudioFeedError(f"{feed.player} still playing after its timeout")
    finally:
        feed.stop()
