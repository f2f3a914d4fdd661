"""Device selection, and the sound card <-> USB port pairing hook, on a fake sysfs tree."""
from __future__ import annotations

import ast
import os
import sys
from pathlib import Path

import pytest

from fingertip.audio import (
    AudioDeviceNotFound, InputDevice, alsa_card_of, find_alsa_card, find_input_device,
    usb_hub_of, usb_path_of_alsa_card, usb_serial_of_alsa_card,
)

AUDIO_PACKAGE = Path(__file__).resolve().parents[2] / "host" / "fingertip" / "audio"


def fake_sysfs(root: Path) -> Path:
    """card0: onboard (PCI), card1: USB card on hub port 1-2.3 with a serial, card2: USB
    without a serial, card3: virtual (no device link), as Linux lays them out."""
    pci = root / "devices" / "pci0000:00" / "0000:00:1f.3"
    usb = root / "devices" / "pci0000:00" / "0000:00:14.0" / "usb1"
    cards = {
        0: pci / "sound" / "card0",
        1: usb / "1-2" / "1-2.3" / "1-2.3:1.0" / "sound" / "card1",
        2: usb / "1-4" / "1-4:1.0" / "sound" / "card2",
        3: root / "devices" / "virtual" / "sound" / "card3",
    }
    (usb / "1-2" / "1-2.3").mkdir(parents=True)
    (usb / "1-2" / "1-2.3" / "serial").write_text("PIEZO-0042\n")
    (usb / "1-2" / "serial").write_text("HUB-SERIAL\n")
    cls = root / "class" / "sound"
    cls.mkdir(parents=True)
    for n, card_dir in cards.items():
        card_dir.mkdir(parents=True)
        # /sys/class/sound/cardN -> ../../devices/.../cardN; cardN/device -> its parent
        os.symlink(os.path.relpath(card_dir, cls), cls / f"card{n}")
        if n != 3:
            os.symlink("../..", card_dir / "device")
    return root


def test_usb_path_and_serial_of_alsa_cards(tmp_path):
    root = fake_sysfs(tmp_path / "sys")
    assert usb_path_of_alsa_card(0, root) is None  # PCI: not USB
    assert usb_path_of_alsa_card(1, root) == "1-2.3"
    assert usb_path_of_alsa_card(2, root) == "1-4"
    assert usb_path_of_alsa_card(3, root) is None  # virtual: no device link
    assert usb_serial_of_alsa_card(1, root) == "PIEZO-0042"
    assert usb_serial_of_alsa_card(2, root) is None
    assert usb_serial_of_alsa_card(0, root) is None
    with pytest.raises(AudioDeviceNotFound, match=r"no ALSA card 7 .*card0, card1"):
        usb_path_of_alsa_card(7, root)


def test_find_card_by_usb_serial_or_port_path(tmp_path):
    root = fake_sysfs(tmp_path / "sys")
    assert find_alsa_card(usb_serial="PIEZO-0042", sysfs_root=root) == 1
    assert find_alsa_card(usb_path="1-4", sysfs_root=root) == 2
    assert find_alsa_card(usb_path="1-2.3:1.0", sysfs_root=root) == 1  # pyserial's form
    with pytest.raises(AudioDeviceNotFound, match=r"card1 \(USB 1-2.3, serial PIEZO-0042\)"):
        find_alsa_card(usb_serial="nope", sysfs_root=root)
    with pytest.raises(ValueError):
        find_alsa_card(sysfs_root=root)
    with pytest.raises(AudioDeviceNotFound, match="no sound cards"):
        find_alsa_card(usb_path="1-1", sysfs_root=tmp_path / "empty")


def test_usb_hub_pairs_an_arduino_with_its_sound_card():
    assert usb_hub_of("1-2.3") == "1-2"
    assert usb_hub_of("1-2.1:1.0") == "1-2"  # pyserial PortInfo.location
    assert usb_hub_of("3-1.4.2") == "3-1.4"
    assert usb_hub_of("1-2") is None  # a root-hub port: no shared hub
    assert usb_hub_of("garbage") is None


def test_alsa_card_number_in_portaudio_names():
    assert alsa_card_of("USB Audio Device: - (hw:2,0)") == 2
    assert alsa_card_of("HDA Intel PCH: ALC3246 Analog (hw:0,0)") == 0
    assert alsa_card_of("pulse") is None


DEVICES = [
    InputDevice(0, "HDA Intel PCH: ALC3246 Analog (hw:0,0)", "ALSA", 2, 44100.0, 0, None),
    InputDevice(2, "USB Audio Device: - (hw:1,0)", "ALSA", 1, 44100.0, 1, "1-2.3"),
    InputDevice(3, "USB Audio Device: - (hw:2,0)", "ALSA", 1, 48000.0, 2, "1-4"),
    InputDevice(5, "pulse", "ALSA", 32, 44100.0),
    InputDevice(6, "pulse monitor", "ALSA", 32, 44100.0),
]


def test_pick_a_device_by_name_or_index():
    assert find_input_device("PULSE", DEVICES).index == 5  # exact name beats substrings
    assert find_input_device("monitor", DEVICES).index == 6
    assert find_input_device("hw:2,0", DEVICES).index == 3
    assert find_input_device(2, DEVICES).usb_path == "1-2.3"
    with pytest.raises(AudioDeviceNotFound, match=r"2 input devices match 'USB Audio'"):
        find_input_device("USB Audio", DEVICES)
    with pytest.raises(AudioDeviceNotFound, match=r"no input device matching 'Scarlett'.*"
                                                  r"\[5\] 'pulse'"):
        find_input_device("Scarlett", DEVICES)
    with pytest.raises(AudioDeviceNotFound, match="index 4"):
        find_input_device(4, DEVICES)
    with pytest.raises(AudioDeviceNotFound, match="no input devices at all"):
        find_input_device("x", [])
    assert "USB 1-2.3" in DEVICES[1].describe()


def test_audio_layer_imports_nothing_above_it():
    """Layer rule: stdlib, numpy, sounddevice, soundfile, its own modules, and the pure
    modules below every layer (the clock fit) only."""
    allowed_top = {"numpy", "sounddevice", "soundfile", "__future__"}
    pure_below = {"clockfit"}
    for path in sorted(AUDIO_PACKAGE.glob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                if node.level == 1:
                    continue  # .ring, .source, ...
                if node.level == 2 and node.module in pure_below:
                    continue
                assert node.level == 0, f"{path.name}: relative import above audio"
                names = [node.module or ""]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            else:
                continue
            for name in names:
                top = name.split(".")[0]
                assert top in allowed_top or top in sys.stdlib_module_names, \
                    f"{path.name} imports {name}"


class _Refuse:
    """A meta-path finder that makes importing sounddevice fail like a missing PortAudio."""

    def __init__(self, exc: Exception) -> None:
        self.exc = exc

    def find_spec(self, name, path=None, target=None):
        if name == "sounddevice":
            raise self.exc
        return None


@pytest.mark.parametrize("exc,needle", [(OSError("PortAudio library not found"),
                                         "libportaudio2"),
                                        (ImportError("No module named 'sounddevice'"),
                                         "pip install sounddevice")])
def test_missing_portaudio_is_a_clear_error(monkeypatch, exc, needle):
    from fingertip.audio import AudioBackendError, SoundDeviceSource, import_sounddevice
    monkeypatch.delitem(sys.modules, "sounddevice", raising=False)
    monkeypatch.setattr(sys, "meta_path", [_Refuse(exc), *sys.meta_path])
    with pytest.raises(AudioBackendError, match=needle):
        import_sounddevice()
    with pytest.raises(AudioBackendError, match=needle):
        SoundDeviceSource("pulse").start()
