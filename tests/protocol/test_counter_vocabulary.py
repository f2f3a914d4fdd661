"""One vocabulary of counters (docs/protocol.md, section 6.1): every counter the firmware, the
host, a recording and `fingertip info` use is listed there once, and every listed counter is
used where the table says. A counter renamed on one side, or a new one left out of the table,
fails here."""
from __future__ import annotations

import json
import re
import subprocess
import sys
from dataclasses import fields
from pathlib import Path

import pytest

from fingertip.device import BridgeStats
from fingertip.protocol import ERROR_KINDS
from fingertip.protocol.messages import STATS_FIELDS
from fingertip.protocol.stream import COUNTER_OF_KIND, DecoderStats
from fingertip.record.recorder import RecorderStats
from fingertip.sim import VirtualFirmware
from fingertip.sim.device.pty_device import PtyDevice

ROOT = Path(__file__).resolve().parents[2]
NOT_COUNTERS = {"timestamp_us"}  # when STATS was sent: a time, not a count


def vocabulary(doc: Path = ROOT / "docs" / "protocol.md") -> dict[str, str]:
    """Counter -> where (device, host, recorder), from the table under the ``counters``
    marker; a name in two rows is an error."""
    text = doc.read_text()
    table = text[text.index("<!-- counters:"):]
    table = table[:table.index("\n\n", table.index("| counter |"))]
    out: dict[str, str] = {}
    for name, where in re.findall(r"^\| `(\w+)` \| (\w+) \|", table, re.M):
        assert name not in out, f"{name} is listed twice"
        out[name] = where
    return out


def names_where(where: str) -> set[str]:
    return {n for n, w in vocabulary().items() if w == where}


def firmware_stats_fields() -> list[str]:
    """The STATS fields of the C++ X-macro in firmware/lib/fingertip_protocol/protocol.h."""
    text = (ROOT / "firmware" / "lib" / "fingertip_protocol" / "protocol.h").read_text()
    return re.findall(r"^\s*X\((\w+)\)", text, re.M)


def test_the_table_names_each_counter_once_and_only_known_places():
    v = vocabulary()
    assert set(v.values()) == {"device", "host", "recorder"}
    assert len(v) >= 30


def test_device_counters_are_the_firmwares_the_vector_files_and_the_hosts():
    vectors = json.loads((ROOT / "tests" / "vectors" / "protocol_v1.json").read_text())
    device = names_where("device")
    assert set(firmware_stats_fields()) - NOT_COUNTERS == device
    assert set(vectors["constants"]["stats_fields"]) - NOT_COUNTERS == device
    assert set(STATS_FIELDS) - NOT_COUNTERS == device


def test_host_counters_are_the_bridges_and_the_decoders():
    used = {f.name for f in fields(DecoderStats)} | {f.name for f in fields(BridgeStats)}
    assert used == names_where("host")


def test_each_error_kind_is_counted_under_a_listed_host_counter():
    host = names_where("host")
    assert set(COUNTER_OF_KIND) == set(ERROR_KINDS)
    assert {COUNTER_OF_KIND[k] for k in ERROR_KINDS} <= host


def test_recorder_counters_are_the_recorders():
    assert {f.name for f in fields(RecorderStats)} == names_where("recorder")


def test_a_drifted_table_is_caught(tmp_path):
    doc = tmp_path / "protocol.md"
    text = (ROOT / "docs" / "protocol.md").read_text()
    doc.write_text(text.replace("| `crc_errors` | host |", "| `crc` | host |"))
    assert "crc_errors" not in vocabulary(doc) and "crc" in vocabulary(doc)
    doc.write_text(text.replace("| `seq_gaps` | host |", "| `frames_ok` | host |"))
    with pytest.raises(AssertionError, match="frames_ok is listed twice"):
        vocabulary(doc)


def test_fingertip_info_prints_the_device_counters_under_their_names(tmp_path):
    exe = str(Path(sys.executable).with_name("fingertip"))
    with PtyDevice(VirtualFirmware(4), link=tmp_path / "ft") as dev:
        r = subprocess.run([exe, "info", "--port", str(dev.link), "--json"],
                           capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    stats = json.loads(r.stdout)["stats"]
    assert set(stats) - {"type", "seq"} - NOT_COUNTERS == names_where("device")
