"""Piezo (contact microphone) capture: sound cards, files and simulators behind one interface.

Every source fills a preallocated :class:`RingBuffer` and hands out :class:`Chunk` objects:
samples ``(frames, channels)`` as captured (int16, int32 or float32), the absolute index of
the first frame, the sample rate and the host ``time.monotonic()`` of the first frame.

* :class:`SoundDeviceSource`: live capture through sounddevice / PortAudio.
* :class:`FileSource`: WAV / FLAC recordings through soundfile.
* :class:`SimulatedSource`: samples computed by a function of time.

Losses are counted in :class:`AudioStats` (``input_overflows``, ``overruns_frames``, ...),
never silent. sounddevice is imported only when a live source starts (or devices are
listed), so that a sound server started by a program (or a test) is seen by PortAudio.
This layer imports nothing above ``fingertip.protocol``. See docs/audio.md.
"""
from .blocks import BlockSource
from .chunk import AudioStats, Chunk
from ..clockfit import FrameClock
from .devices import (
    InputDevice, alsa_card_of, alsa_cards, find_alsa_card, find_input_device, import_sounddevice,
    list_input_devices, refresh_devices, supported_rates, usb_hub_of, usb_path_of_alsa_card,
    usb_serial_of_alsa_card,
)
from .file import FileSource
from .live import SoundDeviceSource
from .ring import RingBuffer
from .simulated import SimulatedSource
from .source import (
    AudioBackendError, AudioDeviceNotFound, AudioError, AudioFileError, AudioSettingsError,
    AudioSource, RingSource,
)

__all__ = [
    "AudioBackendError", "AudioDeviceNotFound", "AudioError", "AudioFileError",
    "AudioSettingsError", "AudioSource", "AudioStats", "BlockSource", "Chunk", "FileSource",
    "FrameClock", "InputDevice", "RingBuffer", "RingSource", "SimulatedSource",
    "SoundDeviceSource", "alsa_card_of", "find_alsa_card", "find_input_device",
    "import_sounddevice", "list_input_devices", "refresh_devices", "supported_rates",
    "alsa_cards", "usb_hub_of", "usb_path_of_alsa_card", "usb_serial_of_alsa_card",
]
