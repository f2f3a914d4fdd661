"""The Python side of the constants shared with the firmware: each one against the single
list in tests/vectors/protocol_v1.json ("constants"), which firmware/test/test_protocol.cpp
checks the C++ headers against (tests/sim/device/test_device_lib.py checks the built library)."""
from __future__ import annotations

from fingertip.protocol import (
    Ack,
    ErrorCode,
    Info,
    MsgType,
    Nack,
    Sample,
    Stats,
    pack_frame,
)
from fingertip.protocol import messages as m
from tests.conftest import load_vectors

C = load_vectors()["constants"]


def test_scalars():
    python = {
        "protocol_major": m.PROTOCOL_MAJOR, "protocol_minor": m.PROTOCOL_MINOR,
        "header_size": m.HEADER_LEN, "crc_size": m.CRC_LEN, "min_frame": m.MIN_FRAME,
        "max_frame": m.MAX_FRAME, "max_encoded": m.MAX_ENCODED,
        "max_channels": m.MAX_CHANNELS, "max_log_text": m.MAX_LOG_TEXT,
        "max_tare_samples": m.MAX_TARE_SAMPLES, "int24_min": m.INT24_MIN,
        "int24_max": m.INT24_MAX, "flag_streaming": m.FLAG_STREAMING,
        "flag_powered_down": m.FLAG_POWERED_DOWN,
        "flag_tare_in_progress": m.FLAG_TARE_IN_PROGRESS,
        "info_reason_request": m.InfoReason.REQUEST, "info_reason_boot": m.InfoReason.BOOT,
        "valid_rates": list(m.VALID_RATES), "valid_gains": list(m.VALID_GAINS),
    }
    assert python == {k: C[k] for k in python}


def test_message_ids_error_codes_and_counter_names():
    assert {t.name.lower(): int(t) for t in MsgType} == C["message_types"]
    assert {e.name.lower(): int(e) for e in ErrorCode} == C["nack_errors"]
    assert list(m.STATS_FIELDS) == C["stats_fields"]


def test_frame_sizes_as_the_codec_writes_them():
    overhead = C["header_size"] + C["crc_size"]

    def payload(msg) -> int:
        return len(pack_frame(msg)) - overhead

    for ch in (1, 4, 16):
        assert payload(Sample(0, 0, (0,) * ch)) == C["sample_payload_fixed"] + 3 * ch
        info = Info(0, 1, 0, (0, 1, 0), 0, 0, 0, ch, 80, 1, 128, 0, 0, (0,) * ch)
        assert payload(info) == C["info_payload_fixed"] + 3 * ch
    assert payload(Stats(0, 0)) == C["stats_payload"]
    assert payload(Ack(0, 1, 1)) == C["ack_payload"]
    assert payload(Nack(0, 1, 1, ErrorCode.BUSY)) == C["nack_payload"]
    # The largest frame (16 channels of INFO) fits max_frame.
    assert overhead + C["info_payload_fixed"] + 3 * C["max_channels"] <= C["max_frame"]
