"""Find fingertips among the serial ports, by USB serial number rather than by port name."""
from __future__ import annotations

from dataclasses import dataclass

from serial.tools import list_ports as _list_ports

from ..errors import DeviceError


class DeviceNotFound(DeviceError, LookupError):
    """No port, or more than one, matched what was asked for (the user's input: exit 2)."""

    exit_code = 2


@dataclass(frozen=True, slots=True)
class PortInfo:
    device: str
    vid: int | None
    pid: int | None
    serial_number: str | None
    location: str | None
    """USB physical path (bus-port.port...), the key for pairing with a sound card."""
    description: str
    manufacturer: str | None

    @property
    def usb(self) -> bool:
        return self.vid is not None

    @property
    def usb_id(self) -> str:
        return f"{self.vid:04x}:{self.pid:04x}" if self.vid is not None else ""


def list_ports(include_non_usb: bool = False) -> list[PortInfo]:
    """Serial ports with their USB identity (non-USB ports only when asked)."""
    out = []
    for p in sorted(_list_ports.comports(), key=lambda p: p.device):
        info = PortInfo(p.device, p.vid, p.pid, p.serial_number, p.location,
                        p.description or "", p.manufacturer)
        if info.usb or include_non_usb:
            out.append(info)
    return out


def find_port(serial_number: str, ports: list[PortInfo] | None = None) -> PortInfo:
    """The one port whose USB serial number is ``serial_number`` (case-insensitive).

    Raises :class:`DeviceNotFound` with the list of what is there when none or several match.
    """
    ports = list_ports() if ports is None else ports
    want = serial_number.strip().lower()
    hits = [p for p in ports if p.serial_number and p.serial_number.lower() == want]
    if len(hits) == 1:
        return hits[0]
    seen = ", ".join(f"{p.device} (serial {p.serial_number or '-'}, {p.usb_id})"
                     for p in ports) or "no USB serial ports at all"
    if not hits:
        raise DeviceNotFound(f"no serial port with USB serial number {serial_number!r}; "
                             f"found: {seen}")
    raise DeviceNotFound(f"{len(hits)} ports share USB serial number {serial_number!r} "
                         f"({', '.join(p.device for p in hits)}): use the port name instead")
