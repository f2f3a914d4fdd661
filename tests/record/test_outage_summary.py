"""A recording session whose device goes away: the frames lost across the outage and the
device's restart are in the summary and in the file's counters; a device that never comes
back is reported while it is away and at the end, with how long it has been gone."""
from __future__ import annotations

import logging
import threading
import time

from fingertip.device.health import GoneReporter
from fingertip.record import Recording
from fingertip.record.session import RecordSettings, record_fingertip
from fingertip.sim import VirtualFirmware
from fingertip.sim.device.pty_device import PtyDevice


def record_while(dev: PtyDevice, settings: RecordSettings, events) -> object:
    """Run ``events`` (a function of the device) on a thread while recording."""
    t = threading.Thread(target=events, args=(dev,), daemon=True)
    t.start()
    summary = record_fingertip(settings, port=str(dev.link))
    t.join(10)
    return summary


def test_outage_frames_and_the_restart_reach_the_summary_and_the_file(tmp_path):
    def outage(dev: PtyDevice) -> None:
        time.sleep(1.0)
        dev.unplug()
        time.sleep(1.0)
        dev.replug(reboot=True)

    out = tmp_path / "run.mcap"
    with PtyDevice(VirtualFirmware(4), link=tmp_path / "ft") as dev:
        s = record_while(dev, RecordSettings(out, name="index", duration=4.0), outage)
    assert s.device_resets == 1 and s.reconnects == 1
    assert s.outage_frames >= 1.0 * 80 - 2 and s.frames_lost == s.outage_frames
    # Nothing else was lost: the frames in the file and those lost make up the run.
    assert abs(s.frames + s.frames_lost - 4.0 * 80) <= 0.35 * 80  # start and stop edges
    assert f"lost {s.frames_lost} ({s.outage_frames} across outages)" in s.text()
    assert "reconnects 1, device resets 1" in s.text() and s.gone_s is None
    counters = Recording(out).link_counters()["index"]
    assert (counters["outage_frames"], counters["device_resets"], counters["reconnects"]) == (
        s.outage_frames, 1, 1)


def test_a_device_that_never_comes_back_is_reported_with_how_long_it_is_gone(tmp_path,
                                                                             caplog):
    def gone(dev: PtyDevice) -> None:
        time.sleep(0.5)
        dev.unplug()

    out = tmp_path / "run.mcap"
    with caplog.at_level(logging.WARNING), \
            PtyDevice(VirtualFirmware(4), link=tmp_path / "ft") as dev:
        s = record_while(dev, RecordSettings(out, name="index", duration=6.5), gone)
    reports = [r.getMessage() for r in caplog.records if "gone for" in r.getMessage()]
    assert reports and reports[0].startswith("index: gone for 5 s, still trying to reconnect")
    assert s.gone_s is not None and 5.5 <= s.gone_s <= 7.5
    assert "; the device gone for the last" in s.text()


def test_the_gone_reporter_repeats_every_few_seconds_until_the_device_is_back(caplog):
    g = GoneReporter(every_s=5.0)
    with caplog.at_level(logging.INFO, logger="fingertip.device.health"):
        for t in (None, 0.0, 2.0, 4.9, 5.0, 6.0, 9.9, 10.2, 12.0, 21.0, None, 3.0, 5.1):
            g.check("index", t, "/dev/ttyACM0")
    said = [r.getMessage() for r in caplog.records]
    assert said == ["index: gone for 5 s, still trying to reconnect on /dev/ttyACM0",
                    "index: gone for 10 s, still trying to reconnect on /dev/ttyACM0",
                    "index: gone for 21 s, still trying to reconnect on /dev/ttyACM0",
                    "index is back",
                    "index: gone for 5 s, still trying to reconnect on /dev/ttyACM0"]
