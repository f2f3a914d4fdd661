"""The fingertip device for the host: the firmware's own C++ (lib/fingertip_core and
lib/fingertip_protocol) on a simulated board, through the device library (:mod:`.device_lib`).

No I/O and no clock of its own: the caller advances device time and moves the bytes, so the
same object runs behind a pty in real time (:mod:`fingertip.sim.device.pty_device`), inside a test
as fast as the library goes, or in lock-step with a physics model. The chips' inputs come
from ``source`` (device time in microseconds -> each chip's input in counts at gain 128),
called only when the chips are read. The firmware-in-the-loop tests compare its output with
the same C++ built for the Uno and run in simavr.
"""
from __future__ import annotations

import ctypes
import weakref
from collections.abc import Callable, Sequence

from ...protocol.messages import STATS_FIELDS
from . import device_lib

CountsSource = Callable[[int], Sequence[float]]
"""Device time in microseconds -> each chip's input in counts (before clipping)."""


def _firmware_version() -> tuple[int, int, int]:
    c = device_lib.constants()
    return c["firmware_major"], c["firmware_minor"], c["firmware_patch"]


def __getattr__(name: str) -> object:
    # FIRMWARE_VERSION comes from the C++ (lazily: importing the simulator must not need the
    # library, only running the device does).
    if name == "FIRMWARE_VERSION":
        return _firmware_version()
    raise AttributeError(name)


class VirtualFirmware:
    """The Uno firmware's device logic, frame for frame, given the chips' inputs.

    ``dead_mask``: chips that never become ready (missing or broken). One thread runs a
    device (boot, receive, advance); others may read its observers.
    """

    def __init__(self, channels: int = 4, source: CountsSource | None = None,
                 build_id: int = 0, reset_cause: int = 1) -> None:
        lib = device_lib.load()
        max_channels = device_lib.constants()["max_channels"]
        if not 1 <= channels <= max_channels:
            raise ValueError(f"channels must be 1..{max_channels}")
        if device_lib.stats_fields() != STATS_FIELDS:
            raise device_lib.DeviceLibraryError(
                f"the device library's STATS fields {device_lib.stats_fields()} differ from "
                f"the host's {STATS_FIELDS}: {device_lib.BUILD_HINT}")
        self.channels = channels
        self.source: CountsSource = source or (lambda t: (0,) * channels)
        self.build_id = build_id
        self.reset_cause = reset_cause
        self._lib = lib
        self._h = lib.ftd_create(channels, build_id, reset_cause)
        if not self._h:
            raise MemoryError("ftd_create failed")
        weakref.finalize(self, lib.ftd_destroy, self._h)
        self._state = device_lib.FtdState()
        self._error: BaseException | None = None
        # Bound through a weak reference: the library holds the callback, which must not keep
        # this object alive.
        ref = weakref.ref(self)
        self._inputs_cb = device_lib.INPUTS_FN(
            lambda ctx, t, out, n: _fill_inputs(ref, t, out, n))
        lib.ftd_set_inputs(self._h, self._inputs_cb, None)

    # --- running ----------------------------------------------------------------------------

    def _output(self, n: int) -> bytes:
        if n < 0:
            self._raise(n)
        if n == 0:
            return b""
        lib, h = self._lib, self._h
        data = ctypes.string_at(lib.ftd_tx_data(h), n)
        lib.ftd_tx_clear(h)
        return data

    def _raise(self, code: int) -> None:
        self._lib.ftd_tx_clear(self._h)
        if code == device_lib.E_INPUTS and self._error is not None:
            err, self._error = self._error, None
            raise err
        if code == device_lib.E_NAN:
            raise ValueError(f"the chips' inputs at {self.now_us} us contain NaN")
        raise RuntimeError(f"device library error {code} at {self.now_us} us")

    def reset(self) -> None:
        """Power-on state at device time 0, as after a reset of the Uno (call :meth:`boot`
        for its output)."""
        self._lib.ftd_reset(self._h)

    def boot(self, start_us: int = 0) -> bytes:
        """Reset, and return the bytes a freshly reset device sends. ``start_us``: the device
        clock at boot (a real one starts at 0; later values test the 32-bit wraparound)."""
        return self._output(self._lib.ftd_boot(self._h, start_us))

    def receive(self, data: bytes) -> bytes:
        """Take host bytes at the current device time; return the immediate answers."""
        return self._output(self._lib.ftd_receive(self._h, data, len(data)))

    def advance(self, to_us: int) -> bytes:
        """Run device time forward to ``to_us``; return what the device sends meanwhile."""
        return self._output(self._lib.ftd_advance(self._h, to_us))

    @property
    def next_due_us(self) -> int | None:
        """Device time of the next thing the device does on its own (a conversion, a chip
        deadline, a statistics frame), or None when nothing is due: a host serving the
        device can sleep until then instead of polling."""
        t = self._lib.ftd_next_due(self._h)
        return None if t < 0 else t

    # --- observers --------------------------------------------------------------------------

    @property
    def now_us(self) -> int:
        return self._lib.ftd_now(self._h)

    @property
    def dead_mask(self) -> int:
        return self._lib.ftd_dead_mask(self._h)

    @dead_mask.setter
    def dead_mask(self, mask: int) -> None:
        if self._lib.ftd_set_dead_mask(self._h, mask) != 0:
            raise ValueError(f"dead_mask {mask:#x}: a {self.channels}-channel device")

    def _read_state(self) -> device_lib.FtdState:
        self._lib.ftd_state(self._h, ctypes.byref(self._state))
        return self._state

    @property
    def rate_sps(self) -> int:
        return self._read_state().rate_sps

    @property
    def decimation(self) -> int:
        return self._read_state().decimation

    @property
    def gain(self) -> int:
        return self._read_state().gain

    @property
    def streaming(self) -> bool:
        return bool(self._read_state().streaming)

    @property
    def powered(self) -> bool:
        return bool(self._read_state().powered)

    @property
    def flags(self) -> int:
        return self._read_state().flags

    @property
    def period_us(self) -> int:
        return 1_000_000 // self.rate_sps

    @property
    def offsets(self) -> list[int]:
        return list(self._read_state().offsets[:self.channels])

    @property
    def counters(self) -> dict[str, int]:
        """The STATS counters now (``timestamp_us`` left out)."""
        return dict(zip(STATS_FIELDS[1:], self._read_state().stats[1:], strict=True))


def _fill_inputs(ref: weakref.ref, t_us: int, out, n: int) -> int:
    """The library's inputs callback: ``source(t_us)`` into ``out``; an exception is kept
    for the call that ran the device to raise."""
    fw = ref()
    if fw is None:
        return 1
    try:
        values = fw.source(t_us)
        for i in range(n):
            out[i] = values[i]
    except BaseException as e:  # noqa: BLE001 - handed back to the caller, never lost
        fw._error = e
        return 1
    return 0
