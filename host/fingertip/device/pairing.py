"""Pair a fingertip's serial port with its USB sound card, so that a hand of four fingertips
with four sound cards needs no device numbers.

The readout board puts the Uno and the sound card behind one USB hub, so the two hang off
the same hub port: the Uno at ``1-2.1``, its sound card at ``1-2.3``. Pairing goes by that
physical path (stable across reboots, unlike ``/dev/ttyACM*`` and ALSA card numbers), or by
an explicit USB serial number of the card when the user knows it.
"""
from __future__ import annotations

import os

from ..errors import EXIT_USAGE, DeviceError
from ..audio import AudioDeviceNotFound, alsa_cards, find_alsa_card, usb_hub_of
from ..transport import PortInfo, list_ports


class PairingError(DeviceError, LookupError):
    """No sound card, or several, could be paired with the port (the user's set-up: exit
    status 2; give the sound card explicitly)."""

    exit_code = EXIT_USAGE


def sound_card_for(port: PortInfo, *, card_serial: str | None = None,
                   sysfs_root: str | os.PathLike = "/sys") -> int:
    """The ALSA card number of the sound card that belongs with ``port``.

    With ``card_serial``: the card with that USB serial number. Otherwise: the one USB
    sound card behind the same hub as the port's device.
    """
    if card_serial is not None:
        try:
            return find_alsa_card(usb_serial=card_serial, sysfs_root=sysfs_root)
        except AudioDeviceNotFound as e:
            raise PairingError(str(e)) from e
    if not port.location:
        raise PairingError(f"{port.device} is not a USB device: pair its sound card by "
                           "serial number (card_serial=...)")
    hub = usb_hub_of(port.location)
    if hub is None:
        raise PairingError(f"{port.device} (USB {port.location}) is not behind a hub, so "
                           "nothing ties a sound card to it: pair by card serial number")
    hits, seen = [], []
    for n, path, _ in alsa_cards(sysfs_root):
        seen.append(f"card{n} (USB {path or '-'})")
        if path is not None and usb_hub_of(path) == hub:
            hits.append(n)
    if len(hits) == 1:
        return hits[0]
    listing = ", ".join(seen) or "no sound cards"
    if not hits:
        raise PairingError(f"no USB sound card behind hub {hub} with {port.device}; "
                           f"cards: {listing}")
    raise PairingError(f"{len(hits)} sound cards behind hub {hub} with {port.device}: "
                       f"{listing}; pair by card serial number")


def alsa_device_name(card: int) -> str:
    """The name PortAudio lists the card's first capture device under (``hw:N,0``)."""
    return f"hw:{int(card)},0"


def port_info(port: str, ports: list[PortInfo] | None = None, *,
              option: str = "--audio") -> PortInfo:
    """The USB identity of serial port ``port`` (a path or a symlink to one); ``option``:
    the caller's option that names a sound card instead, for the error message."""
    listed = {p.device: p for p in (list_ports(include_non_usb=True) if ports is None else ports)}
    info = listed.get(port) or next((p for p in listed.values()
                                     if os.path.realpath(p.device) == os.path.realpath(port)),
                                    None)
    if info is None:
        raise PairingError(f"{port}: not a USB serial port here (ports: "
                           f"{', '.join(listed) or 'none'}); give the sound card with {option}")
    return info


def sound_card_for_port(port: str, *, ports: list[PortInfo] | None = None,
                        sysfs_root: str | os.PathLike = "/sys", option: str = "--audio") -> str:
    """The capture device name (``hw:N,0``) of the sound card paired with the fingertip on
    serial port ``port`` (``ports``: the serial ports, listed here when None); a
    :class:`PairingError` (a LookupError) says why there is none, naming ``option`` as the
    caller's way to give the card instead."""
    return alsa_device_name(sound_card_for(port_info(port, ports, option=option),
                                           sysfs_root=sysfs_root))
