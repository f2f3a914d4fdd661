"""ATI Net F/T (and Axia) Raw Data Transfer (RDT): high-speed force/torque over UDP.

Layout implemented (ATI's Net F/T manual, "RDT"; all fields big-endian, UDP port 49152):

Request, 8 bytes, host -> sensor::

    uint16 command_header = 0x1234
    uint16 command        0x0000 stop streaming, 0x0002 start real-time streaming,
                          0x0003 start buffered streaming, 0x0042 set software bias
    uint32 sample_count   records to send, 0 = until stopped

Response ("RDT record"), 36 bytes, sensor -> host, one per sample::

    uint32 rdt_sequence   counts the records sent (gaps = records lost on the way)
    uint32 ft_sequence    counts the sensor's internal samples
    uint32 status         0 = healthy; other bits are the sensor's error flags
    int32  Fx, Fy, Fz     counts; newtons = counts / counts_per_force
    int32  Tx, Ty, Tz     counts; newton metres = counts / counts_per_torque

``counts_per_force`` and ``counts_per_torque`` are the sensor's configuration (its web page
or ``/netftapi2.xml``: ``cfgcpf``, ``cfgcpt``; 1,000,000 is the usual default). RDT carries no
time stamps: the client stamps arrival times on this host and smooths them against
``rdt_sequence`` (a straight line under the arrivals), so network jitter does not enter.
"""
from __future__ import annotations

import logging
import socket
import struct
import threading
import time
from dataclasses import dataclass

import numpy as np

from .samples import ReferenceError, ReferenceSamples, unusable_text

log = logging.getLogger(__name__)

PORT = 49152
HEADER = 0x1234
CMD_STOP = 0x0000
CMD_START = 0x0002
CMD_START_BUFFERED = 0x0003
CMD_BIAS = 0x0042
REQUEST = struct.Struct(">HHI")
RECORD = struct.Struct(">III6i")
DEFAULT_COUNTS_PER_UNIT = 1_000_000


def encode_request(command: int, sample_count: int = 0) -> bytes:
    return REQUEST.pack(HEADER, command, sample_count)


def decode_request(data: bytes) -> tuple[int, int]:
    """(command, sample_count); ValueError when it is not an RDT request."""
    if len(data) != REQUEST.size:
        raise ValueError(f"RDT request must be {REQUEST.size} bytes, not {len(data)}")
    header, command, count = REQUEST.unpack(data)
    if header != HEADER:
        raise ValueError(f"RDT request header 0x{header:04x}, not 0x{HEADER:04x}")
    return command, count


@dataclass(frozen=True)
class RdtRecord:
    rdt_sequence: int
    ft_sequence: int
    status: int
    counts: tuple[int, int, int, int, int, int]

    def encode(self) -> bytes:
        return RECORD.pack(self.rdt_sequence, self.ft_sequence, self.status, *self.counts)


def decode_record(data: bytes) -> RdtRecord:
    if len(data) != RECORD.size:
        raise ValueError(f"RDT record must be {RECORD.size} bytes, not {len(data)}")
    v = RECORD.unpack(data)
    return RdtRecord(v[0], v[1], v[2], tuple(v[3:]))  # type: ignore[arg-type]


def smooth_arrivals(seq: np.ndarray, arrival: np.ndarray, window: int = 2000) -> np.ndarray:
    """Send times from arrival times: per window of records, the straight line through
    ``seq`` under which no arrival lies (a packet is never early, often late). Returns
    times in the clock of ``arrival``."""
    seq = np.asarray(seq, float)
    arrival = np.asarray(arrival, float)
    out = np.empty_like(arrival)
    for a in range(0, len(seq), window):
        s, t = seq[a:a + window], arrival[a:a + window]
        if len(s) < 3:
            out[a:a + window] = t
            continue
        slope = np.polyfit(s, t, 1)[0]
        # The lower envelope: shift the fitted line down to the earliest arrivals (the 2nd
        # percentile, robust to a clock read glitch).
        base = t - slope * s
        out[a:a + window] = slope * s + np.percentile(base, 2)
    return out


class RdtClient:
    """Streams from an RDT sensor in a thread. ``host``: the sensor's address;
    ``counts_per_force`` / ``counts_per_torque``: its configuration. Implements
    :class:`~.samples.WrenchSource`."""

    def __init__(self, host: str, port: int = PORT, *,
                 counts_per_force: float = DEFAULT_COUNTS_PER_UNIT,
                 counts_per_torque: float = DEFAULT_COUNTS_PER_UNIT,
                 first_packet_timeout: float = 2.0) -> None:
        if not (isinstance(port, int) and 1 <= port <= 65535):
            raise ReferenceError(f"RDT sensor {host}:{port}: the port must be 1-65535")
        self.host, self.port = host, port
        self.name = f"rdt://{host}:{port}"
        self.cpf, self.cpt = float(counts_per_force), float(counts_per_torque)
        self.first_packet_timeout = first_packet_timeout
        self._sock: socket.socket | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._rows: list[tuple[float, int, int, int, tuple[int, ...]]] = []
        self.counters = {"packets": 0, "lost": 0, "bad_size": 0, "status_errors": 0,
                         "foreign": 0}

    def start(self) -> None:
        s = None
        try:
            fam, kind, proto, _, addr = socket.getaddrinfo(self.host, self.port,
                                                           type=socket.SOCK_DGRAM)[0]
            s = socket.socket(fam, kind, proto)
            s.settimeout(0.1)
            s.connect(addr)
        except (OSError, OverflowError, UnicodeError) as e:  # gaierror: an unknown host
            if s is not None:
                s.close()
            raise ReferenceError(f"RDT sensor {self.host}:{self.port}: cannot be reached "
                                 f"({getattr(e, 'strerror', None) or e})") from e
        self._sock = s
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="rdt-client", daemon=True)
        self._thread.start()
        s.send(encode_request(CMD_START, 0))
        deadline = time.monotonic() + self.first_packet_timeout
        while time.monotonic() < deadline and not any(r[3] == 0 for r in self._rows[-50:]):
            time.sleep(0.01)
        if not any(r[3] == 0 for r in self._rows):
            self.stop()
            if why := unusable_text(self.counters):
                raise ReferenceError(f"no usable RDT packets from {self.host}:{self.port} "
                                     f"within {self.first_packet_timeout:g} s{why}")
            raise ReferenceError(f"no RDT packets from {self.host}:{self.port} within "
                                 f"{self.first_packet_timeout:g} s: is the sensor's address "
                                 "right, RDT enabled on its web page, and UDP 49152 open?")

    def _run(self) -> None:
        s = self._sock
        assert s is not None
        last = None
        while not self._stop.is_set():
            try:
                data = s.recv(256)
            except TimeoutError:
                continue
            except OSError as e:  # e.g. ICMP port unreachable: nothing listens there
                log.debug("RDT receive: %s", e)
                time.sleep(0.05)
                continue
            now = time.monotonic()
            if len(data) != RECORD.size:
                self.counters["bad_size"] += 1
                continue
            r = decode_record(data)
            if last is not None:
                gap = (r.rdt_sequence - last - 1) & 0xFFFFFFFF
                if gap < 1 << 31:
                    self.counters["lost"] += gap
                else:
                    continue  # older than what we have: reordered or repeated
            last = r.rdt_sequence
            self.counters["packets"] += 1
            if r.status:
                self.counters["status_errors"] += 1
            self._rows.append((now, r.rdt_sequence, r.ft_sequence, r.status, r.counts))

    def stop(self) -> ReferenceSamples:
        s = self._sock
        if s is not None:
            try:
                s.send(encode_request(CMD_STOP, 0))
            except OSError:
                pass
        self._stop.set()
        if self._thread:
            self._thread.join(timeout=1)
            self._thread = None
        if s is not None:
            s.close()
            self._sock = None
        return self.samples()

    def samples(self) -> ReferenceSamples:
        rows = [r for r in self._rows if r[3] == 0]
        if not rows:
            return ReferenceSamples(np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3)), self.name,
                                    dict(self.counters))
        arrival = np.array([r[0] for r in rows])
        seq = np.unwrap(np.array([r[1] for r in rows], float), period=2.0 ** 32)
        counts = np.array([r[4] for r in rows], float)
        return ReferenceSamples(smooth_arrivals(seq, arrival), counts[:, :3] / self.cpf,
                                counts[:, 3:] / self.cpt, self.name, dict(self.counters))
