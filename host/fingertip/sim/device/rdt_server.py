"""A reference F/T sensor on loopback speaking ATI's RDT (:mod:`fingertip.reference.rdt`):
it streams the virtual fingertip's true forces as a real Net F/T would, with its own
latency, rate, noise, jitter and lost packets, so ``calibrate record`` is tested end to end.
"""
from __future__ import annotations

import logging
import socket
import threading
import time
from collections.abc import Callable

import numpy as np

from ...reference.rdt import (
    CMD_BIAS,
    CMD_START,
    CMD_START_BUFFERED,
    CMD_STOP,
    DEFAULT_COUNTS_PER_UNIT,
    RdtRecord,
    decode_request,
)

log = logging.getLogger(__name__)

ForceAt = Callable[[float], "np.ndarray"]
"""Host monotonic time -> the true (Fx, Fy, Fz) on the fingertip, newtons."""


class RdtServer:
    """Serves RDT on ``host:port`` (port 0: any free one; see :attr:`port`).

    ``delay_s``: how far the sensor's readings lag the truth (its filter and its clock);
    ``noise_n``: force noise rms; ``loss``: fraction of records lost on the way;
    ``rate_hz``: records per second. Packets leave in bursts every couple of milliseconds
    (the serving thread's poll), which is the arrival jitter a client sees. The sensor's
    frame is the fingertip's (no rotation).
    """

    def __init__(self, force_at: ForceAt, *, host: str = "127.0.0.1", port: int = 0,
                 rate_hz: float = 1000.0, delay_s: float = 0.037, noise_n: float = 0.01,
                 loss: float = 0.01,
                 counts_per_force: float = DEFAULT_COUNTS_PER_UNIT, seed: int = 0) -> None:
        self.force_at = force_at
        self.rate_hz = rate_hz
        self.delay_s, self.noise_n, self.loss = delay_s, noise_n, loss
        self.cpf = counts_per_force
        self._rng = np.random.default_rng(seed)
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._sock.bind((host, port))
        self._sock.settimeout(0.002)
        self.host, self.port = self._sock.getsockname()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._bias = np.zeros(3)
        self.sent = 0
        self.dropped = 0

    def start(self) -> RdtServer:
        self._thread = threading.Thread(target=self._run, name="rdt-server", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread:
            self._thread.join(timeout=2)
        self._sock.close()

    def __enter__(self) -> RdtServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _reading(self, t: float) -> np.ndarray:
        f = np.asarray(self.force_at(t - self.delay_s), float)
        return f + self._rng.normal(0.0, self.noise_n, 3) - self._bias

    def _run(self) -> None:
        client = None
        remaining = 0
        seq = 0
        t0 = 0.0
        k = 0
        period = 1.0 / self.rate_hz
        while not self._stop.is_set():
            try:
                data, addr = self._sock.recvfrom(64)
                cmd, count = decode_request(data)
                if cmd in (CMD_START, CMD_START_BUFFERED):
                    client, remaining = addr, count or -1
                    t0, k = time.monotonic(), 0
                elif cmd == CMD_STOP:
                    client = None
                elif cmd == CMD_BIAS:
                    self._bias = self._bias + self._reading(time.monotonic())
            except TimeoutError:
                pass
            except ValueError as e:
                log.debug("not an RDT request: %s", e)
            except OSError:
                return
            if client is None:
                continue
            now = time.monotonic()
            while client is not None and t0 + k * period <= now:
                ts = t0 + k * period
                k += 1
                seq = (seq + 1) & 0xFFFFFFFF
                f = self._reading(ts)
                rec = RdtRecord(seq, (seq * 7) & 0xFFFFFFFF, 0,
                                (*(int(round(v * self.cpf)) for v in f), 0, 0, 0))
                if self._rng.random() < self.loss:
                    self.dropped += 1
                else:
                    try:
                        self._sock.sendto(rec.encode(), client)
                        self.sent += 1
                    except OSError:
                        client = None
                if remaining > 0:
                    remaining -= 1
                    if remaining == 0:
                        client = None
