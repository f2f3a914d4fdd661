"""Pairing a fingertip's serial port with its sound card, on a fake sysfs tree."""
from __future__ import annotations

import pytest

from fingertip.device.pairing import (
    PairingError,
    alsa_device_name,
    port_info,
    sound_card_for,
    sound_card_for_port,
)
from fingertip.transport import DeviceNotFound, PortInfo, find_port
from tests.audio.test_devices import fake_sysfs


def port(location, serial="UNO-1", device="/dev/ttyACM0"):
    return PortInfo(device, 0x2341, 0x0043, serial, location, "Arduino Uno", "Arduino")


def test_pairs_by_hub_and_by_serial(tmp_path):
    root = fake_sysfs(tmp_path / "sys")  # card1 at 1-2.3 (serial PIEZO-0042), card2 at 1-4
    assert sound_card_for(port("1-2.1:1.0"), sysfs_root=root) == 1
    assert sound_card_for(port(None), card_serial="PIEZO-0042", sysfs_root=root) == 1
    assert alsa_device_name(1) == "hw:1,0"


def test_clear_errors(tmp_path):
    root = fake_sysfs(tmp_path / "sys")
    with pytest.raises(PairingError, match="no USB sound card behind hub 1-7"):
        sound_card_for(port("1-7.1:1.0"), sysfs_root=root)
    with pytest.raises(PairingError, match="not behind a hub"):
        sound_card_for(port("1-4:1.0"), sysfs_root=root)
    with pytest.raises(PairingError, match="not a USB device"):
        sound_card_for(port(None), sysfs_root=root)
    with pytest.raises(PairingError, match="no sound card with USB serial"):
        sound_card_for(port(None), card_serial="NOPE", sysfs_root=root)


def test_find_port_by_serial_none_or_several():
    ports = [port("1-2.1", "A1", "/dev/ttyACM0"), port("1-3.1", "B2", "/dev/ttyACM1"),
             port("1-4.1", "B2", "/dev/ttyACM2")]
    assert find_port("a1", ports).device == "/dev/ttyACM0"
    with pytest.raises(DeviceNotFound, match="no serial port with USB serial number 'Z9'"):
        find_port("Z9", ports)
    with pytest.raises(DeviceNotFound, match="2 ports share USB serial number 'B2'"):
        find_port("B2", ports)


def test_a_port_path_or_its_link_finds_its_paired_card(tmp_path):
    """One lookup for every command that pairs by port (classify --port, publish --audio
    paired): the port by path or through a symlink, then its card by hub."""
    root = fake_sysfs(tmp_path / "sys")
    ports = [port("1-2.1:1.0", device=str(tmp_path / "ttyACM0")), port("1-4.1", "UNO-2",
                                                                        "/dev/ttyACM9")]
    (tmp_path / "ttyACM0").touch()
    (tmp_path / "fingertip").symlink_to(tmp_path / "ttyACM0")
    assert port_info(str(tmp_path / "fingertip"), ports) is ports[0]
    assert sound_card_for_port(str(tmp_path / "ttyACM0"), ports=ports, sysfs_root=root) == "hw:1,0"
    with pytest.raises(PairingError, match="not a USB serial port here"):
        sound_card_for_port("/dev/ttyUSB7", ports=ports, sysfs_root=root)
    # check's option for the card is --audio-device, publish's --audio: each is named
    with pytest.raises(PairingError, match="with --audio-device$"):
        sound_card_for_port("/dev/ttyUSB7", ports=ports, sysfs_root=root,
                            option="--audio-device")
    with pytest.raises(PairingError, match="with --audio$"):
        sound_card_for_port("/dev/ttyUSB7", ports=ports, sysfs_root=root)
    with pytest.raises(LookupError, match="no USB sound card behind hub"):
        sound_card_for_port("/dev/ttyACM9", ports=ports, sysfs_root=root)
