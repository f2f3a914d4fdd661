"""`--hand`, `--hand-split`, `--finger-names`, `--hand-audio`: parsing and one-line errors."""
from __future__ import annotations

import argparse

import numpy as np
import pytest
import soundfile as sf

from fingertip.hand_args import (AudioInput, add_hand_args, hand_audio_from_args,
                                 hand_audio_inputs, hand_spec_from_args,
                                 parse_assignments, parse_split)


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser()
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--port")
    g.add_argument("--serial")
    add_hand_args(p, g)
    return p


def test_assignments_keep_order_and_strip():
    assert list(parse_assignments(" index=/dev/ttyACM0 , thumb=COM3")) == ["index", "thumb"]
    assert parse_assignments("a=x=y") == {"a": "x=y"}


@pytest.mark.parametrize("text, msg", [
    ("index", "not NAME=VALUE"), ("index=", "not NAME=VALUE"), ("=p", "finger name ''"),
    ("a=p,,b=q", "empty entry"), ("a=p,a=q", "given twice"), ("9a=p", "must start"),
    ("a-b=p", "must start"),
])
def test_bad_assignments(text, msg):
    with pytest.raises(ValueError, match=msg):
        parse_assignments(text)


def test_split_edges():
    assert parse_split("4x4") == {"f0": (0, 1, 2, 3), "f1": (4, 5, 6, 7),
                                  "f2": (8, 9, 10, 11), "f3": (12, 13, 14, 15)}
    assert parse_split(" 2X8 ", ["a", "b"]) == {"a": tuple(range(8)), "b": tuple(range(8, 16))}
    assert parse_split("1x1") == {"f0": (0,)}
    assert parse_split("16x1", [f"c{k}" for k in range(16)])["c15"] == (15,)
    for bad, msg in [("4", "not FINGERSxCHANNELS"), ("4x", "not"), ("x4", "not"),
                     ("-1x4", "not"), ("0x4", "1..16"), ("4x0", "1..16"), ("17x1", "1..16"),
                     ("4x5", "1..16"), ("9x1", "name the 9 fingers")]:
        with pytest.raises(ValueError, match=msg):
            parse_split(bad)
    with pytest.raises(ValueError, match="3 names for 4"):
        parse_split("4x4", ["a", "b", "c"])
    with pytest.raises(ValueError, match="twice"):
        parse_split("2x2", ["a", "a"])


def test_spec_from_args():
    p = parser()
    assert hand_spec_from_args(p.parse_args(["--port", "P"])) is None
    s = hand_spec_from_args(p.parse_args(["--port", "P", "--hand-split", "4x4",
                                          "--finger-names", "i,m,r,t"]))
    assert s.port == "P" and s.fingers == ["i", "m", "r", "t"] and s.groups["t"] == (12, 13,
                                                                                    14, 15)
    s = hand_spec_from_args(p.parse_args(["--hand", "i=A,m=B"]))
    assert s.ports == {"i": "A", "m": "B"} and s.groups is None
    for argv, msg in [(["--hand", "i=A", "--hand-split", "2x2"], "splits one device"),
                      (["--hand", "i=A", "--finger-names", "x"], "names the --hand-split"),
                      (["--port", "P", "--finger-names", "x"], "need --hand"),
                      (["--port", "P", "--hand-audio", "x"], "need --hand")]:
        with pytest.raises(ValueError, match=msg):
            hand_spec_from_args(p.parse_args(argv))
    with pytest.raises(SystemExit):   # --hand and --port exclude each other
        p.parse_args(["--hand", "i=A", "--port", "P"])


def test_hand_audio_sources(tmp_path):
    p = parser()
    four = tmp_path / "four.wav"
    sf.write(four, np.zeros((100, 4), np.int16), 44100)
    mono = tmp_path / "mono.wav"
    sf.write(mono, np.zeros((100, 1), np.int16), 44100)
    a = p.parse_args(["--port", "P", "--hand-split", "4x4", "--hand-audio", str(four)])
    [(src, names)] = hand_audio_from_args(a, ["f0", "f1", "f2", "f3"])
    assert names == ["f0", "f1", "f2", "f3"] and src.channels == 4
    a = p.parse_args(["--hand", "i=A,m=B", "--hand-audio", f"i={mono},m={mono}"])
    got = hand_audio_from_args(a, ["i", "m"])
    assert [n for _, n in got] == [["i"], ["m"]]
    a = p.parse_args(["--hand", "i=A", "--hand-audio", f"x={mono}"])
    with pytest.raises(ValueError, match="no finger named 'x'"):
        hand_audio_from_args(a, ["i"])
    a = p.parse_args(["--port", "P", "--hand-split", "4x4", "--hand-audio", str(mono)])
    with pytest.raises(ValueError, match="1 channel"):
        hand_audio_from_args(a, ["f0", "f1", "f2", "f3"])


def test_repeatable_port_options_give_one_device_to_split():
    """check and publish take --port/--serial repeatedly; a split needs exactly one."""
    p = argparse.ArgumentParser()
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--port", action="append")
    g.add_argument("--serial", action="append")
    add_hand_args(p, g)
    s = hand_spec_from_args(p.parse_args(["--port", "P", "--hand-split", "2x2"]))
    assert s.port == "P" and s.serial is None and s.fingers == ["f0", "f1"]
    s = hand_spec_from_args(p.parse_args(["--serial", "SN1", "--hand-split", "2x2"]))
    assert s.serial == "SN1" and s.port is None
    with pytest.raises(ValueError, match="give one --port, not 2"):
        hand_spec_from_args(p.parse_args(["--port", "P", "--port", "Q", "--hand-split", "4x4"]))


def test_hand_audio_inputs_name_each_fingers_input():
    p = parser()
    a = p.parse_args(["--port", "P", "--hand-split", "2x2", "--finger-names", "i,m",
                      "--hand-audio", "UMC404HD"])
    got = hand_audio_inputs(a, ["i", "m"])
    assert got == {"i": AudioInput("UMC404HD", 0, 2), "m": AudioInput("UMC404HD", 1, 2)}
    a = p.parse_args(["--hand", "i=A,m=B", "--hand-audio", "m=3,i=card.wav"])
    got = hand_audio_inputs(a, ["i", "m"])
    assert got["m"].card == 3 and not got["m"].is_file and got["i"].is_file
    assert hand_audio_inputs(p.parse_args(["--port", "P"]), ["x"]) == {}
