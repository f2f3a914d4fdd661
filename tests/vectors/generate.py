#!/usr/bin/env python3
"""Write tests/vectors/protocol_v1.json, the shared test vectors of wire protocol v1.

This generator packs frames with its own few lines of struct, COBS and CRC code, written from
docs/protocol.md and independent of both codecs, so that the vectors check the codecs instead
of echoing them. Run it after changing the protocol; tests fail if the file is stale.

    python tests/vectors/generate.py            # rewrite the file
    python tests/vectors/generate.py --check    # exit 1 if the file differs
"""
from __future__ import annotations

import argparse
import binascii
import json
import struct
import sys
from pathlib import Path

OUT = Path(__file__).with_name("protocol_v1.json")

DEVICE_TYPES = {"sample": 0x81, "info": 0x82, "stats": 0x83, "ack": 0x84, "nack": 0x85, "log": 0x86}
COMMAND_TYPES = {
    "ping": 0x01, "get_info": 0x02, "start": 0x03, "stop": 0x04, "tare": 0x05,
    "set_rate": 0x06, "set_gain": 0x07, "reset_counters": 0x08, "set_power": 0x09,
    "get_stats": 0x0A, "set_tare_offsets": 0x0B,
}
STATS_FIELDS = [
    "timestamp_us", "frames_sent", "read_timeouts", "saturations", "command_errors",
    "rx_overflows", "rx_crc_errors", "rx_framing_errors", "tx_overruns", "longest_loop_us",
]
NACK_ERRORS = {"unknown_command": 1, "bad_length": 2, "bad_argument": 3, "busy": 4,
               "chip_timeout": 5, "powered_down": 6}


def constants() -> dict:
    """The constants C++ and Python share, listed once: firmware/test/test_protocol.cpp checks
    the C++ headers against them, tests/protocol/test_constants.py the Python package and the
    device library (docs/protocol.md has the meaning of each)."""
    return {
        "protocol_major": 1, "protocol_minor": 0,
        "header_size": 3, "crc_size": 2, "min_frame": 5, "max_frame": 128, "max_encoded": 129,
        "max_channels": 16, "max_log_text": 100, "max_tare_samples": 256,
        "int24_min": -(1 << 23), "int24_max": (1 << 23) - 1,
        # Payload sizes of section 4; SAMPLE and INFO add 3 bytes per channel.
        "sample_payload_fixed": struct.calcsize("<IBHH"),
        "info_payload_fixed": struct.calcsize("<BB3BIBBBBBBBH"),
        "stats_payload": struct.calcsize("<10I"), "ack_payload": struct.calcsize("<HB"),
        "nack_payload": struct.calcsize("<HBB"),
        "flag_streaming": 0x01, "flag_powered_down": 0x02, "flag_tare_in_progress": 0x04,
        "info_reason_request": 0, "info_reason_boot": 1,
        "valid_rates": [10, 80], "valid_gains": [128, 64, 32],
        "message_types": {**COMMAND_TYPES, **DEVICE_TYPES},
        "nack_errors": NACK_ERRORS,
        "stats_fields": STATS_FIELDS,
    }


def crc16(data: bytes) -> int:
    return binascii.crc_hqx(data, 0xFFFF)


def cobs(data: bytes) -> bytes:
    out = bytearray()
    block = bytearray()
    for b in data:
        if b == 0:
            out.append(len(block) + 1)
            out += block
            block.clear()
        else:
            block.append(b)
            if len(block) == 254:
                out.append(255)
                out += block
                block.clear()
    out.append(len(block) + 1)
    out += block
    return bytes(out)


def i24(v: int) -> bytes:
    assert -(1 << 23) <= v < (1 << 23), v
    return (v & 0xFFFFFF).to_bytes(3, "little")


def frame(type_: int, seq: int, payload: bytes) -> bytes:
    body = struct.pack("<BH", type_, seq) + payload
    return body + struct.pack("<H", crc16(body))


def payload_of(m: dict) -> tuple[int, bytes]:
    t = m["type"]
    if t == "sample":
        p = struct.pack("<IBHH", m["timestamp_us"], len(m["values"]), m["timeout_mask"],
                        m["saturation_mask"])
        return DEVICE_TYPES[t], p + b"".join(i24(v) for v in m["values"])
    if t == "info":
        p = struct.pack("<BB3BIBBBBBBBH", m["protocol_major"], m["protocol_minor"],
                        *m["firmware_version"], m["build_id"], m["reason"], m["reset_cause"],
                        m["channels"], m["rate_sps"], m["decimation"], m["gain"], m["flags"],
                        m["tare_mask"])
        return DEVICE_TYPES[t], p + b"".join(i24(v) for v in m["tare_offsets"])
    if t == "stats":
        return DEVICE_TYPES[t], struct.pack("<10I", *(m[k] for k in STATS_FIELDS))
    if t == "ack":
        return DEVICE_TYPES[t], struct.pack("<HB", m["request_id"], m["command"])
    if t == "nack":
        return DEVICE_TYPES[t], struct.pack("<HBB", m["request_id"], m["command"], m["error"])
    if t == "log":
        return DEVICE_TYPES[t], bytes([m["level"]]) + m["text"].encode("utf-8")
    if t == "tare":
        return COMMAND_TYPES[t], struct.pack("<HH", m["channel_mask"], m["samples"])
    if t == "set_rate":
        return COMMAND_TYPES[t], struct.pack("<BB", m["rate_sps"], m["decimation"])
    if t == "set_gain":
        return COMMAND_TYPES[t], struct.pack("<B", m["gain"])
    if t == "set_power":
        return COMMAND_TYPES[t], struct.pack("<B", m["on"])
    if t == "set_tare_offsets":
        mask = m["channel_mask"]
        chosen = [v for i, v in enumerate(m["offsets"]) if mask >> i & 1]
        return COMMAND_TYPES[t], struct.pack("<H", mask) + b"".join(i24(v) for v in chosen)
    return COMMAND_TYPES[t], b""


def wire(m: dict) -> bytes:
    type_, payload = payload_of(m)
    seq = m["seq"] if m["type"] in DEVICE_TYPES else m["request_id"]
    return cobs(frame(type_, seq, payload)) + b"\x00"


def sample(seq, ts, values, timeout_mask=0, saturation_mask=0):
    return {"type": "sample", "seq": seq, "timestamp_us": ts, "values": values,
            "timeout_mask": timeout_mask, "saturation_mask": saturation_mask}


def info(seq, reason, channels, offsets=None, **kw):
    offsets = offsets if offsets is not None else [0] * channels
    m = {"type": "info", "seq": seq, "protocol_major": 1, "protocol_minor": 0,
         "firmware_version": [0, 1, 0], "build_id": 0x1A2B3C4D, "reason": reason,
         "reset_cause": 1, "channels": channels, "rate_sps": 80, "decimation": 1, "gain": 128,
         "flags": 0, "tare_mask": sum(1 << i for i, v in enumerate(offsets) if v),
         "tare_offsets": offsets}
    m.update(kw)
    return m


def valid_frames() -> list[dict]:
    v = []

    def add(name, direction, message):
        v.append({"name": name, "direction": direction, "message": message})

    add("sample_4ch_basic", "device", sample(7, 1_000_000, [1, -2, 300, -40000]))
    add("sample_4ch_extremes", "device",
        sample(8, 1_012_500, [0x7FFFFF, -0x800000, -1, 0], saturation_mask=0b0011))
    add("sample_4ch_zeros", "device", sample(0, 0, [0, 0, 0, 0]))
    add("sample_4ch_timeout", "device",
        sample(9, 1_025_000, [12345, 0, -12345, 99], timeout_mask=0b0010))
    add("sample_seq_65535", "device", sample(65535, 4_294_967_295, [100, 200, 300, 400]))
    add("sample_seq_wrapped_0", "device", sample(0, 0, [101, 201, 301, 401]))
    add("sample_16ch", "device",
        sample(42, 123_456_789,
               [0x7FFFFF, -0x800000, -1, 0, 1, -2, 1000, -1000, 65535, -65536, 0x123456,
                -0x123456, 0x00FF00, 0x0000FF, 0x7F0000, -0x7F0000],
               timeout_mask=0x8000, saturation_mask=0x0003))
    add("sample_1ch", "device", sample(3, 17, [-8]))
    add("sample_with_zero_bytes", "device", sample(256, 0x01000000, [0x010000, 0x000100, 0, 0]))
    add("info_boot_4ch", "device", info(0, 1, 4, reset_cause=8))
    add("info_reply_4ch_tared", "device",
        info(12, 0, 4, [-123456, 654321, 0, -1], flags=1, decimation=8, rate_sps=80, gain=64))
    add("info_16ch", "device",
        info(13, 0, 16, [i * 1000 - 8000 for i in range(16)], flags=0b110, rate_sps=10,
             gain=32))
    add("stats_typical", "device",
        {"type": "stats", "seq": 200, "timestamp_us": 60_000_000, "frames_sent": 4802,
         "read_timeouts": 3, "saturations": 1, "command_errors": 2, "rx_overflows": 1,
         "rx_crc_errors": 4, "rx_framing_errors": 5, "tx_overruns": 0,
         "longest_loop_us": 1500})
    add("stats_max", "device",
        dict({"type": "stats", "seq": 65535}, **{k: 0xFFFFFFFF for k in STATS_FIELDS}))
    add("ack_ping_1", "device", {"type": "ack", "seq": 1, "request_id": 1, "command": 0x01})
    add("ack_tare_65535", "device",
        {"type": "ack", "seq": 77, "request_id": 65535, "command": 0x05})
    add("nack_bad_argument", "device",
        {"type": "nack", "seq": 78, "request_id": 9, "command": 0x06, "error": 3})
    add("nack_unknown_command", "device",
        {"type": "nack", "seq": 79, "request_id": 10, "command": 0x7E, "error": 1})
    add("log_boot", "device", {"type": "log", "seq": 1, "level": 1, "text": "boot fw 0.1.0"})
    add("log_empty", "device", {"type": "log", "seq": 2, "level": 3, "text": ""})
    add("log_max", "device", {"type": "log", "seq": 3, "level": 2, "text": "x" * 100})
    add("log_utf8", "device", {"type": "log", "seq": 4, "level": 0, "text": "gain 128 µV ok"})

    add("ping_request_1", "host", {"type": "ping", "request_id": 1})
    add("ping_request_0", "host", {"type": "ping", "request_id": 0})
    add("get_info", "host", {"type": "get_info", "request_id": 2})
    add("start", "host", {"type": "start", "request_id": 3})
    add("stop", "host", {"type": "stop", "request_id": 65535})
    add("tare_all_64", "host", {"type": "tare", "request_id": 4, "channel_mask": 0x000F,
                                "samples": 64})
    add("tare_clear_16ch", "host", {"type": "tare", "request_id": 5, "channel_mask": 0xFFFF,
                                    "samples": 0})
    add("tare_one_256", "host", {"type": "tare", "request_id": 6, "channel_mask": 0x0004,
                                 "samples": 256})
    add("set_rate_80_1", "host", {"type": "set_rate", "request_id": 7, "rate_sps": 80,
                                  "decimation": 1})
    add("set_rate_10_255", "host", {"type": "set_rate", "request_id": 8, "rate_sps": 10,
                                    "decimation": 255})
    add("set_gain_64", "host", {"type": "set_gain", "request_id": 9, "gain": 64})
    add("reset_counters", "host", {"type": "reset_counters", "request_id": 10})
    add("set_power_off", "host", {"type": "set_power", "request_id": 11, "on": 0})
    add("set_power_on", "host", {"type": "set_power", "request_id": 12, "on": 1})
    add("get_stats", "host", {"type": "get_stats", "request_id": 256})
    # offsets: one per channel (16), only the masked ones travel; the others read as 0.
    add("set_tare_offsets_4ch", "host",
        {"type": "set_tare_offsets", "request_id": 13, "channel_mask": 0x000F,
         "offsets": [-123456, 654321, 0, -1] + [0] * 12})
    add("set_tare_offsets_sparse_16ch", "host",
        {"type": "set_tare_offsets", "request_id": 14, "channel_mask": 0x8001,
         "offsets": [0x7FFFFF] + [0] * 14 + [-0x800000]})
    for item in v:
        item["hex"] = wire(item["message"]).hex()
    return v


def enc(raw: bytes) -> bytes:
    """COBS-encode an already packed frame and add the delimiter."""
    return cobs(raw) + b"\x00"


def invalid_inputs() -> list[dict]:
    good = frame(0x81, 7, struct.pack("<IBHH", 1000, 4, 0, 0) + i24(1) * 4)
    ping = frame(0x01, 1, b"")
    v = []

    def add(name, direction, data, error, note, command_error=None):
        item = {"name": name, "direction": direction, "hex": data.hex(), "error": error,
                "note": note}
        if command_error is not None:
            # What the device answers to this intact but malformed command (NACK error code).
            item["nack_error"] = command_error
        v.append(item)

    bad = bytearray(good)
    bad[10] ^= 0x01
    add("bad_crc_bitflip", "any", enc(bytes(bad)), "crc", "one payload bit flipped")
    bad = bytearray(good)
    bad[-1] ^= 0xFF
    add("bad_crc_in_crc", "any", enc(bytes(bad)), "crc", "CRC high byte corrupted")
    add("bad_crc_big_endian", "any", enc(good[:-2] + good[-2:][::-1]), "crc",
        "CRC sent high byte first (a common implementation mistake)")
    add("bad_crc_init_zero", "any",
        enc(good[:-2] + struct.pack("<H", binascii.crc_hqx(good[:-2], 0))), "crc",
        "CRC computed with initial value 0 instead of 0xFFFF")
    add("truncated_frame", "any", enc(good[:-3]), "crc", "last three bytes of the frame lost")
    add("truncated_encoded", "any", cobs(good)[:-1] + b"\x00", "cobs",
        "last encoded byte lost: the final code byte points past the end")
    add("truncated_header", "any", enc(b"\x81\x07"), "too_short", "two bytes only")
    add("four_bytes", "any", enc(b"\x81\x07\x00\x12"), "too_short", "one byte short of a frame")
    add("cobs_code_past_end", "any", bytes([0x05, 0x11, 0x22, 0x00]), "cobs",
        "code byte 5 with two data bytes")
    add("cobs_single_code", "any", bytes([0x09, 0x00]), "cobs", "lone code byte")
    add("over_long", "any", bytes([0xFF] + [0x41] * 254) + b"\x00", "too_long",
        "255 bytes before the delimiter (limit 129)")
    add("over_long_by_one", "any", bytes([0x41]) * 130 + b"\x00", "too_long",
        "130 bytes before the delimiter")
    add("unknown_type", "any", enc(frame(0x7E, 5, b"\x01\x02")), "unknown_type",
        "type 0x7E is defined in neither direction", command_error=1)
    add("unknown_device_type", "device", enc(frame(0xFE, 5, b"")), "unknown_type",
        "type 0xFE is not a device message")
    add("command_to_host", "device", enc(ping), "unknown_type",
        "a PING arriving at a host is not a device message")
    add("device_msg_to_device", "host", enc(good), "unknown_type",
        "a SAMPLE arriving at the device is not a command", command_error=1)
    add("empty", "any", b"\x00", "empty", "two delimiters in a row: counted, not an error")
    add("sample_short_payload", "device",
        enc(frame(0x81, 7, struct.pack("<IBHH", 1000, 4, 0, 0) + i24(1) * 3)), "bad_payload",
        "four channels announced, three sent")
    add("sample_zero_channels", "device", enc(frame(0x81, 7, struct.pack("<IBHH", 1, 0, 0, 0))),
        "bad_payload", "zero channels")
    add("sample_17_channels", "device",
        enc(frame(0x81, 7, struct.pack("<IBHH", 1, 17, 0, 0) + i24(0) * 17)), "bad_payload",
        "more than 16 channels")
    add("sample_mask_beyond_channels", "device",
        enc(frame(0x81, 7, struct.pack("<IBHH", 1, 4, 0x10, 0) + i24(0) * 4)), "bad_payload",
        "timeout bit set for channel 4 of a 4-channel frame")
    add("info_short", "device", enc(frame(0x82, 1, bytes([1, 0, 0, 1, 0]))), "bad_payload",
        "INFO cut after five bytes")
    add("ack_short", "device", enc(frame(0x84, 1, b"\x01")), "bad_payload", "ACK of one byte")
    add("log_bad_level", "device", enc(frame(0x86, 1, b"\x09hi")), "bad_payload", "level 9")
    add("tare_short", "host", enc(frame(0x05, 4, b"\x0f\x00\x40")), "bad_payload",
        "TARE with three payload bytes", command_error=2)
    add("ping_with_payload", "host", enc(frame(0x01, 4, b"\x00")), "bad_payload",
        "PING must have no payload", command_error=2)
    add("set_rate_bad_rate", "host", enc(frame(0x06, 4, b"\x14\x01")), "bad_payload",
        "rate 20 is neither 10 nor 80", command_error=3)
    add("set_rate_zero_decimation", "host", enc(frame(0x06, 4, b"\x50\x00")), "bad_payload",
        "decimation 0", command_error=3)
    add("set_gain_bad", "host", enc(frame(0x07, 4, b"\x10")), "bad_payload", "gain 16",
        command_error=3)
    add("tare_zero_mask", "host", enc(frame(0x05, 4, struct.pack("<HH", 0, 10))),
        "bad_payload", "channel mask 0", command_error=3)
    add("tare_too_many_samples", "host", enc(frame(0x05, 4, struct.pack("<HH", 1, 257))),
        "bad_payload", "257 samples", command_error=3)
    add("set_tare_offsets_zero_mask", "host", enc(frame(0x0B, 4, b"\x00\x00")),
        "bad_payload", "channel mask 0", command_error=3)
    add("set_tare_offsets_length_mismatch", "host",
        enc(frame(0x0B, 4, b"\x03\x00" + i24(5))), "bad_payload",
        "two channels in the mask, one offset sent", command_error=2)
    add("set_tare_offsets_no_mask", "host", enc(frame(0x0B, 4, b"\x03")), "bad_payload",
        "one payload byte: not even a mask", command_error=2)
    add("set_power_bad", "host", enc(frame(0x09, 4, b"\x02")), "bad_payload", "on = 2",
        command_error=3)
    return v


def streams() -> list[dict]:
    """Byte streams with the messages and counters a decoder must produce."""
    s = []

    def add(name, direction, chunks, messages, counters, note):
        s.append({"name": name, "direction": direction,
                  "hex": b"".join(chunks).hex(), "messages": messages,
                  "counters": counters, "note": note})

    a = sample(65534, 4_294_967_000, [1, 2, 3, 4])
    b = sample(65535, 4_294_967_295, [5, 6, 7, 8])
    c = sample(0, 0, [9, 10, 11, 12])
    d = sample(1, 12_500, [13, 14, 15, 16])
    add("sequence_and_time_wrap", "device", [wire(a), wire(b), wire(c), wire(d)],
        [a, b, c, d], {"frames_ok": 4, "seq_gaps": 0, "frames_lost": 0},
        "seq 65535 then 0 and timestamp 2^32-1 then 0 are not gaps")
    e = sample(10, 1000, [1, 1, 1, 1])
    f = sample(13, 38500, [2, 2, 2, 2])
    add("gap_of_two", "device", [wire(e), wire(f)], [e, f],
        {"frames_ok": 2, "seq_gaps": 1, "frames_lost": 2}, "seq 10 then 13: two frames lost")
    g = sample(65535, 5, [0, 0, 0, 0])
    h = sample(2, 50005, [0, 0, 0, 0])
    add("gap_across_wrap", "device", [wire(g), wire(h)], [g, h],
        {"frames_ok": 2, "seq_gaps": 1, "frames_lost": 2}, "seq 65535 then 2: 0 and 1 lost")
    i = sample(500, 99, [7, 7, 7, 7])
    boot = info(0, 1, 4)
    j = sample(1, 100, [8, 8, 8, 8])
    add("reset_is_not_a_gap", "device", [wire(i), wire(boot), wire(j)], [i, boot, j],
        {"frames_ok": 3, "seq_gaps": 0, "frames_lost": 0, "device_resets": 1},
        "a boot INFO restarts the numbering")
    k = sample(20, 1, [1, 2, 3, 4])
    m = sample(21, 2, [5, 6, 7, 8])
    add("resync_after_garbage", "device",
        [b"\x13\x37\xff\x00", wire(k), b"\x05\x11\x00", wire(m)], [k, m],
        {"frames_ok": 2, "seq_gaps": 0, "frames_lost": 0, "errors": {"cobs": 2}},
        "garbage before the first delimiter and a broken frame between two good ones")
    n = sample(30, 3, [1, 1, 1, 1])
    o = sample(31, 4, [2, 2, 2, 2])
    add("leading_delimiters", "device", [b"\x00\x00", wire(n), b"\x00", wire(o)], [n, o],
        {"frames_ok": 2, "empty_frames": 3}, "padding zeros are skipped and counted as empty")
    p = sample(40, 5, [3, 3, 3, 3])
    add("over_long_then_good", "device", [bytes([0x41]) * 300 + b"\x00", wire(p)], [p],
        {"frames_ok": 1, "errors": {"too_long": 1}},
        "an over-long run is one error, and the next frame is recovered")
    return s


def build() -> dict:
    return {
        "protocol": {"major": 1, "minor": 0},
        "limits": {"max_frame": 128, "max_encoded": 129, "max_channels": 16,
                   "max_log_text": 100},
        "constants": constants(),
        "crc": [{"ascii": "123456789", "crc": 0x29B1},
                {"ascii": "", "crc": 0xFFFF},
                {"hex": "010100", "crc": crc16(bytes.fromhex("010100"))}],
        "cobs": [
            {"decoded": d.hex(), "encoded": cobs(d).hex()}
            for d in [b"", b"\x00", b"\x00\x00", b"\x11\x22\x00\x33", b"\x11\x22\x33\x44",
                      b"\x11\x00\x00\x00", bytes(range(1, 255)), bytes(range(0, 255)),
                      bytes(range(1, 256)), bytes(range(2, 256)) + b"\x00",
                      bytes(range(3, 256)) + b"\x00\x01"]
        ],
        "frames": valid_frames(),
        "invalid": invalid_inputs(),
        "streams": streams(),
    }


def render() -> str:
    return json.dumps(build(), indent=1, ensure_ascii=False) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="fail if the file is out of date")
    args = ap.parse_args()
    text = render()
    if args.check:
        if not OUT.exists() or OUT.read_text(encoding="utf-8") != text:
            print(f"{OUT} is out of date: run {Path(__file__).name}", file=sys.stderr)
            return 1
        return 0
    OUT.write_text(text, encoding="utf-8")
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
