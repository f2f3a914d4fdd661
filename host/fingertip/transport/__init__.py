"""Transport layer: byte streams to a device (serial port, pty) and device discovery."""
from .base import ByteStream, TransportClosed, TransportError
from .discovery import DeviceNotFound, PortInfo, find_port, list_ports
from .serial_port import SerialStream, open_serial

__all__ = ["ByteStream", "DeviceNotFound", "PortInfo", "SerialStream", "TransportClosed",
           "TransportError", "find_port", "list_ports", "open_serial"]
