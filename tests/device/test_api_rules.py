"""The public API refuses calls in the wrong order, out-of-range arguments and use after
close with an exception that names the rule, instead of a silent None, a hang or a
struct error from deep inside."""
from __future__ import annotations

import time

import numpy as np
import pytest

from fingertip import Fingertip
from fingertip.device import Hand, NotConnected
from fingertip.record import Recorder, RecorderError, Recording
from fingertip.record.replay import Replay
from fingertip.sim import VirtualFirmware
from fingertip.sim.device.pty_device import PtyDevice


@pytest.fixture
def device(tmp_path):
    with PtyDevice(VirtualFirmware(4), link=tmp_path / "tty") as dev:
        yield dev


# --- Fingertip ----------------------------------------------------------------------------

@pytest.mark.realtime
def test_read_on_a_never_opened_device_raises_at_once():
    ft = Fingertip("/dev/nothing-here")
    t0 = time.monotonic()
    with pytest.raises(NotConnected, match="never opened: call open"):
        ft.read(timeout=5)
    with pytest.raises(NotConnected, match="never opened"):
        ft.start()
    with pytest.raises(NotConnected, match="never opened"):
        list(ft.frames(timeout=5))
    assert time.monotonic() - t0 < 1.0  # not after the timeouts


def test_read_after_close_hands_out_what_came_then_raises(device):
    ft = Fingertip(str(device.link)).open()
    ft.start()
    assert ft.read(timeout=2) is not None
    time.sleep(0.1)
    ft.close()
    left = 0
    with pytest.raises(NotConnected, match="is closed: open"):
        while ft.read(timeout=5) is not None:
            left += 1
    assert left >= 1
    with pytest.raises(NotConnected, match="is closed"):
        ft.tare()
    ft.open()  # open again: usable again
    assert ft.channels == 4
    ft.close()


@pytest.mark.realtime
def test_close_from_another_thread_wakes_a_waiting_reader(device):
    import threading

    ft = Fingertip(str(device.link)).open()
    threading.Timer(0.3, ft.close).start()
    t0 = time.monotonic()
    with pytest.raises(NotConnected):
        ft.read(timeout=10)
    assert time.monotonic() - t0 < 3


def test_frames_end_when_closed_during_iteration(device):
    ft = Fingertip(str(device.link)).open()
    ft.start()
    n = 0
    for _ in ft.frames(timeout=2):
        n += 1
        if n == 5:
            ft.close()
    assert n >= 5


@pytest.mark.parametrize("samples, match", [
    (100000, r"tare samples must be in 0\.\.256, not 100000"),
    (-1, r"tare samples must be in 0\.\.256"),
    (257, r"0\.\.256"),
])
def test_tare_samples_out_of_range(device, samples, match):
    # A 3.2 s tare on a virtual device that a test worker runs: the answer's allowance is
    # generous, as a caller on a busy host would make it (the test is about the range).
    with Fingertip(str(device.link), command_timeout=5.0) as ft:
        with pytest.raises(ValueError, match=match):
            ft.tare(samples=samples)
        with pytest.raises(TypeError, match="must be an integer"):
            ft.tare(samples=2.5)
        assert ft.tare(samples=256) is not None  # the top of the range is accepted


def test_commands_name_their_allowed_values(device):
    with Fingertip(str(device.link)) as ft:
        with pytest.raises(ValueError, match="rate must be one of 10, 80"):
            ft.set_rate(40)
        with pytest.raises(ValueError, match=r"decimation must be in 1\.\.255"):
            ft.set_rate(80, 0)
        with pytest.raises(ValueError, match="gain must be one of 128, 64, 32"):
            ft.set_gain(100)
        with pytest.raises(ValueError, match=r"tare offset must be in -8388608\.\.8388607"):
            ft.set_tare_offsets([0, 0, 1 << 23, 0])
        with pytest.raises(ValueError, match="at least one channel"):
            ft.tare(channels=[])
        with pytest.raises(ValueError, match="tare channel mask"):
            ft.tare(channels=0)
        with pytest.raises(ValueError, match="need 4 offsets"):
            ft.set_tare_offsets([1, 2])
        ft.set_rate(10, 3)  # and the legal ones still work
        assert ft.get_info().decimation == 3


@pytest.mark.parametrize("kw, match", [
    ({"queue_size": -1}, "queue_size"), ({"retries": -1}, "retries"),
    ({"command_timeout": 0}, "command_timeout"),
    ({"open_timeout": float("nan")}, "open_timeout"),
])
def test_constructor_arguments(kw, match):
    with pytest.raises(ValueError, match=match):
        Fingertip("/dev/x", **kw)
    with pytest.raises(ValueError, match="exactly one of port or serial_number"):
        Fingertip()
    with pytest.raises(ValueError, match="timeout must be >= 0"):
        Fingertip("/dev/x").read(timeout=-1)


# --- Hand ---------------------------------------------------------------------------------

def test_hand_rules(device):
    ft = Fingertip(str(device.link))
    with pytest.raises(ValueError, match="share one device"):
        Hand({"index": ft, "thumb": ft})
    with pytest.raises(ValueError, match="channel 1 is given to both"):
        Hand.split(ft, {"index": [0, 1], "thumb": [1, 2]})
    with pytest.raises(ValueError, match=r"not in 0\.\.15"):
        Hand.split(ft, {"index": [0, 16]})
    with pytest.raises(ValueError, match="has no channels"):
        Hand.split(ft, {"index": []})
    hand = Hand.split(ft, {"index": [0, 1], "thumb": [2, 3]})
    with pytest.raises(NotConnected, match="call open"):
        hand.read(timeout=5)
    with pytest.raises(KeyError, match="no finger named 'ring'"):
        hand.device("ring")
    with pytest.raises(ValueError, match=r"tare samples must be in 0\.\.256"):
        hand.tare(samples=100000)
    too_wide = Hand.split(Fingertip(str(device.link)), {"index": [0, 5]})
    with pytest.raises(ValueError, match="uses channel 5, but .* has 4"):
        too_wide.open()
    assert all(s == "closed" for s in too_wide.status.values())
    with hand:
        hand.start()
        assert hand.read(timeout=2) is not None
    with pytest.raises(NotConnected):
        while hand.read(timeout=2) is not None:
            pass


# --- Recorder and Replay ------------------------------------------------------------------

def test_recorder_order(tmp_path):
    rec = Recorder(tmp_path / "a.mcap")
    rec.add_device("early", info={"declared": "before start"})  # kept until start()
    with pytest.raises(RecorderError, match=r"write_event before start\(\)"):
        rec.write_event("a", "x")
    with pytest.raises(RecorderError, match="before start"):
        rec.flush()
    rec.start()
    assert rec.write_event("a", "x")
    rec.close()
    with pytest.raises(RecorderError, match=r"write_event after close\(\)"):
        rec.write_event("a", "y")
    with pytest.raises(RecorderError, match="cannot start again"):
        rec.start()
    with pytest.raises(RecorderError, match="is closed"):
        rec.add_device("b")
    assert [r.kind for r in Recording(tmp_path / "a.mcap").records()] == ["info", "events"]
    assert Recording(tmp_path / "a.mcap").info("early") == {"declared": "before start"}
    for kw, match in (({"flush_interval": 0}, "flush_interval"),
                      ({"flush_interval": float("inf")}, "flush_interval"),
                      ({"queue_size": 0}, "queue_size"), ({"compression": "gz"}, "compression")):
        with pytest.raises(ValueError, match=match):
            Recorder(tmp_path / "b.mcap", **kw)


def test_replay_read_before_open_raises(tmp_path):
    with Recorder(tmp_path / "r.mcap") as rec:
        from fingertip import Frame
        for k in range(3):
            rec.write_frame("a", Frame(k, k * 12500, 1.0 + k / 80, 1.0, (1, 2, 3, 4)))
    rp = Replay(tmp_path / "r.mcap", speed=None)
    with pytest.raises(NotConnected, match="never opened: call open"):
        rp.read(timeout=1)
    with rp:
        rp.start()
        assert len(list(rp.frames(timeout=2))) == 3
    assert rp.read(timeout=0.1) is None  # played to the end: the end of the stream
    with pytest.raises(ValueError, match="speed"):
        Replay(tmp_path / "r.mcap", speed=0)
    with pytest.raises(ValueError, match="queue_size"):
        Replay(tmp_path / "r.mcap", queue_size=0)


# --- models -------------------------------------------------------------------------------

def test_force_model_arguments(tmp_path):
    from fingertip.models.force.calibrate import fit_affine, from_arrays, model_metadata
    from fingertip.models.force.runtime import ForceModel

    rng = np.random.default_rng(0)
    counts = rng.normal(size=(50, 4)) * 1e4
    force = counts[:, :2] * 1e-4
    d = from_arrays(counts, force[:, 0], force[:, 1], angle_deg=rng.choice([-20, 20], 50))
    m = fit_affine(d.counts, d.force)
    path = m.to_onnx(tmp_path / "f.onnx", model_metadata(m, d, d)) or tmp_path / "f.onnx"
    with pytest.raises(ValueError, match="gain must be 128, 64 or 32"):
        ForceModel(path, gain=100)
    with pytest.raises(ValueError, match="threads must be an integer >= 1"):
        ForceModel(path, threads=0)
    with pytest.raises(ValueError, match="range_margin"):
        ForceModel(path, range_margin=-1)
    fm = ForceModel(path)
    with pytest.raises(ValueError, match="4 channels"):
        fm.estimate(np.zeros(3))
