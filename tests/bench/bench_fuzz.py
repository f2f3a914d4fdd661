"""Fuzzing both sides of the wire protocol: how much ran, and whether anything broke.

C++: the libFuzzer targets of firmware/fuzz (the COBS decoder and the command receiver,
clang with ASan + UBSan, seeded from tests/vectors/protocol_v1.json) run for
``CPP_SECONDS`` each through ``make -C firmware/fuzz run``; executions and crashing targets
are summed. Python: the host's :class:`~fingertip.protocol.StreamDecoder` (both directions)
is fed for ``PY_SECONDS`` with random bytes and with valid frames damaged at random (bits
flipped, bytes cut, inserted, delimiters moved), in chunks of random sizes; every exception
that escapes ``feed()`` is counted (it must never raise on bad bytes).
"""
from __future__ import annotations

import json
import os
import random
import shutil
import subprocess
import time
from pathlib import Path

from fingertip.protocol import StreamDecoder

ROOT = Path(__file__).resolve().parents[2]
VECTORS = ROOT / "tests" / "vectors" / "protocol_v1.json"
CPP_SECONDS = int(os.environ.get("FUZZ_BENCH_SECONDS", "30"))
PY_SECONDS = float(os.environ.get("FUZZ_BENCH_PY_SECONDS", "20"))

DESCRIPTION = {
    "fuzz_cpp_execs": ("libFuzzer executions of the firmware's COBS decoder and command "
                       f"receiver ({CPP_SECONDS} s each, ASan + UBSan)", (">=", 1)),
    "fuzz_cpp_crashes": ("fuzz targets that crashed or broke a property", ("<=", 0)),
    "fuzz_py_bytes": (f"bytes fed to the Python stream decoders (device and host direction) "
                      f"in {PY_SECONDS:g} s (random "
                      "and damaged frames, random chunking)", (">=", 1)),
    "fuzz_py_escaped": ("exceptions that escaped StreamDecoder.feed() on those bytes",
                        ("<=", 0)),
}


def _cpp() -> dict[str, int]:
    if shutil.which("clang++") is None:
        raise RuntimeError("clang++ is missing: make setup installs it (APT_FUZZ)")
    subprocess.run(["make", "--no-print-directory", "-C", str(ROOT / "firmware" / "fuzz"),
                    "run", f"SECONDS={CPP_SECONDS}"], check=False,
                   timeout=CPP_SECONDS * 4 + 300)
    stats = json.loads((ROOT / "firmware" / "build" / "fuzz" / "stats.json").read_text())
    return {"fuzz_cpp_execs": int(stats["execs"]), "fuzz_cpp_crashes": int(stats["crashes"])}


def _damaged(rng: random.Random, frames: list[bytes]) -> bytes:
    out = bytearray()
    for _ in range(rng.randint(1, 20)):
        f = bytearray(rng.choice(frames))
        what = rng.random()
        if what < 0.3 and f:
            i = rng.randrange(len(f))
            f[i] ^= 1 << rng.randrange(8)
        elif what < 0.45 and f:
            del f[rng.randrange(len(f)):]
        elif what < 0.6:
            f.insert(rng.randrange(len(f) + 1), rng.randrange(256))
        elif what < 0.7 and f:
            f[rng.randrange(len(f))] = 0
        out += f
    return bytes(out)


def _python() -> dict[str, int]:
    v = json.loads(VECTORS.read_text(encoding="utf-8"))
    frames = [bytes.fromhex(f["hex"]) for f in v["frames"] + v["invalid"] + v["streams"]]
    rng = random.Random(18)
    decoders = [StreamDecoder("device"), StreamDecoder("host")]
    fed = escaped = 0
    t_end = time.monotonic() + PY_SECONDS
    while time.monotonic() < t_end:
        data = rng.randbytes(rng.randint(1, 65536)) if rng.random() < 0.5 \
            else _damaged(rng, frames)
        pos = 0
        while pos < len(data):
            n = rng.randint(1, 4096)
            piece = data[pos:pos + n]
            pos += n
            for dec in decoders:
                try:
                    dec.feed(piece)
                except Exception:  # noqa: BLE001 - counting exactly these is the point
                    escaped += 1
            fed += len(piece)
    return {"fuzz_py_bytes": fed, "fuzz_py_escaped": escaped}


def run() -> dict[str, int]:
    return {**_cpp(), **_python()}


if __name__ == "__main__":
    print(run())
