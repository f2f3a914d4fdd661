"""Write libFuzzer seed corpora from the shared vector file (tests/vectors/protocol_v1.json).

    python3 make_seeds.py VECTORS OUTDIR

OUTDIR/receiver: the wire bytes of every host-direction frame, invalid frame and stream
(delimiters included), and all host frames back to back; OUTDIR/cobs: the COBS-encoded
bytes (no delimiter) of every COBS vector and of every frame. Standard library only.
"""
from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path


def write(folder: Path, data: bytes) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / hashlib.sha1(data).hexdigest()).write_bytes(data)


def main(vectors: str, out: str) -> int:
    v = json.loads(Path(vectors).read_text(encoding="utf-8"))
    rx, cobs = Path(out) / "receiver", Path(out) / "cobs"
    host = []
    for f in v["frames"] + v["invalid"] + v["streams"]:
        wire = bytes.fromhex(f["hex"])
        if f.get("direction") in ("host", "any"):
            write(rx, wire)
            host.append(wire)
        for part in wire.split(b"\0"):
            if part:
                write(cobs, part)
    write(rx, b"".join(host))
    for c in v["cobs"]:
        write(cobs, bytes.fromhex(c["encoded"]))
    n_rx = len(list(rx.iterdir()))
    n_cobs = len(list(cobs.iterdir()))
    print(f"seeds: {n_rx} receiver, {n_cobs} cobs", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:3]))
