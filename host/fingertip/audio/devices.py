"""Find sound cards: PortAudio input devices, and the USB port behind an ALSA card.

sounddevice is imported lazily (:func:`import_sounddevice`): PortAudio enumerates the devices
once, when it is initialised at import, so anything that changes what exists (a sound card
plugged in, a PulseAudio server started, ``PULSE_SERVER`` set) must happen before the import,
or be followed by :func:`refresh_devices`.

Pairing a fingertip with its sound card without device numbers: on Linux,
``/sys/class/sound/cardN/device`` links to the USB interface of a USB sound card, whose
parent directory is the USB device (``1-2.3``: bus 1, port 2, hub port 3; it holds the
``serial`` file when the card has one). pyserial reports the same path for the fingertip's
Arduino as ``PortInfo.location`` (``1-2.1:1.0``). :func:`usb_path_of_alsa_card` and
:func:`usb_serial_of_alsa_card` give a card's side; the device layer pairs a serial port and
a card that share a hub (``usb_hub_of``), or a card whose serial number it was told.
"""
from __future__ import annotations

import logging
import os
import re
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

from .source import AudioBackendError, AudioDeviceNotFound

log = logging.getLogger(__name__)

_USB_DEVICE = re.compile(r"^\d+-\d+(\.\d+)*$")
_ALSA_HW = re.compile(r"\(hw:(\d+),(\d+)\)")
COMMON_RATES = (8000, 11025, 16000, 22050, 32000, 44100, 48000, 88200, 96000, 192000)


def import_sounddevice() -> ModuleType:
    """Import sounddevice, with a clear error when PortAudio is missing."""
    try:
        import sounddevice
    except OSError as e:  # the wheel does not bundle PortAudio on Linux
        raise AudioBackendError(
            f"PortAudio is not available ({e}): install the Debian package libportaudio2 "
            "(make setup does), or your system's PortAudio library") from e
    except ImportError as e:
        raise AudioBackendError(f"sounddevice is not installed ({e}): "
                                "pip install sounddevice") from e
    return sounddevice


def refresh_devices() -> None:
    """Make PortAudio enumerate the devices again (no stream may be open).

    Needed after a card is plugged in or a sound server is started once sounddevice has
    been imported. A no-op when sounddevice has not been imported yet.
    """
    import sys
    sd = sys.modules.get("sounddevice")
    if sd is None:
        return
    # sounddevice has no public call for this; these two are what its import does.
    sd._terminate()
    sd._initialize()


@dataclass(frozen=True, slots=True)
class InputDevice:
    """One PortAudio device that can record."""

    index: int
    name: str
    hostapi: str
    max_input_channels: int
    default_samplerate: float
    alsa_card: int | None = None
    """ALSA card number, for ALSA hardware devices named ``... (hw:N,M)``."""
    usb_path: str | None = None
    """USB device path (``1-2.3``) of that card, when it is a USB card."""

    def describe(self) -> str:
        usb = f", USB {self.usb_path}" if self.usb_path else ""
        return (f"[{self.index}] {self.name!r} ({self.hostapi}, {self.max_input_channels} in, "
                f"{self.default_samplerate:g} Hz{usb})")


def alsa_card_of(name: str) -> int | None:
    """The ALSA card number in a PortAudio device name such as ``USB Audio: - (hw:2,0)``."""
    m = _ALSA_HW.search(name)
    return int(m.group(1)) if m else None


def list_input_devices(sysfs_root: str | os.PathLike = "/sys") -> list[InputDevice]:
    """Every device with input channels, with its host API and (Linux) USB path."""
    sd = import_sounddevice()
    apis = sd.query_hostapis()
    out = []
    for i, d in enumerate(sd.query_devices()):
        if d["max_input_channels"] <= 0:
            continue
        card = alsa_card_of(d["name"])
        usb = None
        if card is not None:
            try:
                usb = usb_path_of_alsa_card(card, sysfs_root)
            except AudioDeviceNotFound:
                usb = None
        out.append(InputDevice(i, d["name"], apis[d["hostapi"]]["name"],
                               int(d["max_input_channels"]), float(d["default_samplerate"]),
                               card, usb))
    return out


def _listing(devices: list[InputDevice]) -> str:
    if not devices:
        return ("no input devices at all (no sound card, no sound server, or PortAudio was "
                "initialised before the server started: see refresh_devices)")
    return "; ".join(d.describe() for d in devices)


def find_input_device(device: int | str | None = None,
                      devices: list[InputDevice] | None = None) -> InputDevice:
    """The one input device meant by ``device``.

    None: PortAudio's default input. An int: that device index. A string: the device whose
    name contains it (case-insensitive; an exact name wins over substrings). Raises
    :class:`AudioDeviceNotFound` listing the input devices when none or several match.
    """
    devices = list_input_devices() if devices is None else devices
    if device is None:
        sd = import_sounddevice()
        try:
            index = sd.query_devices(kind="input")["index"]
        except Exception as e:  # PortAudioError, or no default
            raise AudioDeviceNotFound(f"no default input device ({e}); input devices: "
                                      f"{_listing(devices)}") from e
        device = int(index)
    if isinstance(device, int):
        for d in devices:
            if d.index == device:
                return d
        raise AudioDeviceNotFound(f"no input device with index {device}; input devices: "
                                  f"{_listing(devices)}")
    want = device.strip().lower()
    exact = [d for d in devices if d.name.lower() == want]
    if len(exact) == 1:
        return exact[0]
    hits = exact or [d for d in devices if want in d.name.lower()]
    if len(hits) == 1:
        return hits[0]
    if not hits:
        raise AudioDeviceNotFound(f"no input device matching {device!r}; input devices: "
                                  f"{_listing(devices)}")
    raise AudioDeviceNotFound(f"{len(hits)} input devices match {device!r}: "
                              f"{_listing(hits)}; use a longer name or the index")


def supported_rates(device: int, channels: int, dtype: str,
                    rates: tuple[int, ...] = COMMON_RATES) -> list[int]:
    """Which of the common sample rates the device accepts with these settings."""
    sd = import_sounddevice()
    ok = []
    for r in rates:
        try:
            sd.check_input_settings(device=device, channels=channels, dtype=dtype,
                                    samplerate=r)
        except Exception:  # PortAudioError: not this rate
            continue
        ok.append(r)
    return ok


# --- Linux sysfs: sound card <-> USB port ----------------------------------------------------

def _card_dir(card_index: int, sysfs_root: str | os.PathLike) -> Path:
    cls = Path(sysfs_root) / "class" / "sound"
    card = cls / f"card{int(card_index)}"
    if not card.exists():
        present = sorted(p.name for p in cls.glob("card*")) if cls.is_dir() else []
        raise AudioDeviceNotFound(f"no ALSA card {card_index} in {cls} "
                                  f"(cards: {', '.join(present) or 'none'})")
    return card


def _usb_device_dir(card_index: int, sysfs_root: str | os.PathLike) -> Path | None:
    link = _card_dir(card_index, sysfs_root) / "device"
    if not link.exists():
        return None  # a virtual card (snd-aloop, snd-dummy) has no device
    real = Path(os.path.realpath(link))
    for p in (real, *real.parents):
        if _USB_DEVICE.match(p.name):
            return p
    return None


def usb_path_of_alsa_card(card_index: int, sysfs_root: str | os.PathLike = "/sys"
                          ) -> str | None:
    """USB device path (``1-2.3``) of ALSA card ``card_index``; None when it is not USB.

    Reads ``<sysfs_root>/class/sound/card<N>/device``. Raises :class:`AudioDeviceNotFound`
    when the card does not exist.
    """
    dev = _usb_device_dir(card_index, sysfs_root)
    return dev.name if dev is not None else None


def usb_serial_of_alsa_card(card_index: int, sysfs_root: str | os.PathLike = "/sys"
                            ) -> str | None:
    """USB serial number of ALSA card ``card_index`` (None: not USB, or no serial number)."""
    dev = _usb_device_dir(card_index, sysfs_root)
    if dev is None:
        return None
    try:
        return (dev / "serial").read_text(encoding="utf-8", errors="replace").strip() or None
    except OSError:
        return None


def usb_hub_of(usb_path: str) -> str | None:
    """The hub port path a USB device hangs off (``1-2.3`` -> ``1-2``; ``1-2`` -> None).

    Accepts pyserial's ``location`` form too (``1-2.1:1.0``).
    """
    dev = usb_path.split(":", 1)[0]
    if not _USB_DEVICE.match(dev) or "." not in dev:
        return None
    return dev.rsplit(".", 1)[0]


def alsa_cards(sysfs_root: str | os.PathLike = "/sys"
               ) -> list[tuple[int, str | None, str | None]]:
    """Every ALSA card in sysfs as ``(card number, USB path, USB serial)`` (None where the
    card is not on USB or has no serial), in card order."""
    cls = Path(sysfs_root) / "class" / "sound"
    out = []
    for card in sorted(cls.glob("card*")) if cls.is_dir() else []:
        try:
            n = int(card.name[4:])
        except ValueError:
            continue
        out.append((n, usb_path_of_alsa_card(n, sysfs_root),
                    usb_serial_of_alsa_card(n, sysfs_root)))
    return out


def find_alsa_card(*, usb_serial: str | None = None, usb_path: str | None = None,
                   sysfs_root: str | os.PathLike = "/sys") -> int:
    """The ALSA card number of the USB sound card with this serial number or USB path."""
    if (usb_serial is None) == (usb_path is None):
        raise ValueError("give exactly one of usb_serial or usb_path")
    seen = []
    hits = []
    for n, path, serial in alsa_cards(sysfs_root):
        seen.append(f"card{n} (USB {path or '-'}, serial {serial or '-'})")
        if usb_serial is not None and serial is not None and serial == usb_serial:
            hits.append(n)
        if usb_path is not None and path == usb_path.split(":", 1)[0]:
            hits.append(n)
    want = f"USB serial {usb_serial!r}" if usb_serial is not None else f"USB path {usb_path!r}"
    if len(hits) == 1:
        return hits[0]
    listing = ", ".join(seen) or "no sound cards"
    if not hits:
        raise AudioDeviceNotFound(f"no sound card with {want}; cards: {listing}")
    raise AudioDeviceNotFound(f"{len(hits)} sound cards with {want}: {listing}")
