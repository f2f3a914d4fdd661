"""Load the device library: lib/fingertip_core and lib/fingertip_protocol of the firmware on a
simulated board, built for the host by ``make -C firmware hostlib``
(firmware/hostlib/fingertip_device.h is its C API).

There is no Python copy of the firmware to fall back on: without the library (or with one
older than the C++ sources of a checkout) loading fails with a message that says how to build
it, instead of silently running different logic.
"""
from __future__ import annotations

import ctypes
import os
from functools import cache
from pathlib import Path

LIB_NAME = "libfingertip_device.so"
ENV_VAR = "FINGERTIP_DEVICE_LIB"
"""Path of the library to load instead of the checkout's build."""
_ROOT = Path(__file__).resolve().parents[4]
FIRMWARE_DIR = _ROOT / "firmware"
DEFAULT_PATH = FIRMWARE_DIR / "build" / "host" / LIB_NAME
_SOURCE_DIRS = ("lib/fingertip_core", "lib/fingertip_protocol", "hostlib")
BUILD_HINT = (f"run `make -C firmware hostlib` in the fingertip checkout (or set {ENV_VAR} to "
              "the library's path)")

INPUTS_FN = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_uint64,
                             ctypes.POINTER(ctypes.c_double), ctypes.c_uint8)
"""C type of the callback that gives the chips' inputs (``ftd_inputs_fn``)."""

E_INPUTS, E_NAN, E_STUCK, E_ARGUMENT = -1, -2, -3, -4


class DeviceLibraryError(RuntimeError):
    """The device library is missing, stale or does not match this host package."""


class FtdState(ctypes.Structure):
    """``FtdState`` of fingertip_device.h."""

    _fields_ = [(name, ctypes.c_uint8) for name in
                ("channels", "rate_sps", "decimation", "gain", "flags", "streaming",
                 "powered", "tare_active")] + [
        ("live_mask", ctypes.c_uint16), ("stale_mask", ctypes.c_uint16),
        ("offsets", ctypes.c_int32 * 16), ("stats", ctypes.c_uint32 * 10)]


_SIGNATURES: dict[str, tuple[object, list[object]]] = {
    "ftd_create": (ctypes.c_void_p, [ctypes.c_uint8, ctypes.c_uint32, ctypes.c_uint8]),
    "ftd_destroy": (None, [ctypes.c_void_p]),
    "ftd_reset": (None, [ctypes.c_void_p]),
    "ftd_set_inputs": (None, [ctypes.c_void_p, INPUTS_FN, ctypes.c_void_p]),
    "ftd_set_dead_mask": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_uint16]),
    "ftd_dead_mask": (ctypes.c_uint16, [ctypes.c_void_p]),
    "ftd_boot": (ctypes.c_int64, [ctypes.c_void_p, ctypes.c_uint64]),
    "ftd_receive": (ctypes.c_int64, [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_size_t]),
    "ftd_advance": (ctypes.c_int64, [ctypes.c_void_p, ctypes.c_uint64]),
    "ftd_next_due": (ctypes.c_int64, [ctypes.c_void_p]),
    "ftd_now": (ctypes.c_uint64, [ctypes.c_void_p]),
    "ftd_tx_data": (ctypes.c_void_p, [ctypes.c_void_p]),
    "ftd_tx_size": (ctypes.c_size_t, [ctypes.c_void_p]),
    "ftd_tx_clear": (None, [ctypes.c_void_p]),
    "ftd_state": (None, [ctypes.c_void_p, ctypes.POINTER(FtdState)]),
    "ftd_constant": (ctypes.c_int, [ctypes.c_char_p, ctypes.POINTER(ctypes.c_int64)]),
    "ftd_constant_name": (ctypes.c_char_p, [ctypes.c_int]),
    "ftd_stats_field": (ctypes.c_char_p, [ctypes.c_int]),
}


def library_path() -> Path:
    env = os.environ.get(ENV_VAR)
    return Path(env) if env else DEFAULT_PATH


def _newest_source() -> Path | None:
    files = [p for d in _SOURCE_DIRS if (FIRMWARE_DIR / d).is_dir()
             for p in (FIRMWARE_DIR / d).iterdir() if p.suffix in (".cpp", ".h")]
    return max(files, key=lambda p: p.stat().st_mtime, default=None)


@cache
def load() -> ctypes.CDLL:
    """The loaded library with its signatures declared (once per process)."""
    path = library_path()
    if not path.is_file():
        raise DeviceLibraryError(f"the virtual fingertip needs the device library {path}, "
                                 f"which is not built: {BUILD_HINT}")
    newest = None if os.environ.get(ENV_VAR) else _newest_source()
    if newest is not None and newest.stat().st_mtime > path.stat().st_mtime:
        raise DeviceLibraryError(f"the device library {path} is older than {newest}: "
                                 f"{BUILD_HINT}")
    try:
        # PyDLL keeps the GIL across the (microsecond) calls: no release and re-take per call.
        lib = ctypes.PyDLL(str(path))
    except OSError as e:
        raise DeviceLibraryError(f"cannot load the device library {path} ({e}): "
                                 f"{BUILD_HINT}") from None
    for name, (restype, argtypes) in _SIGNATURES.items():
        try:
            fn = getattr(lib, name)
        except AttributeError:
            raise DeviceLibraryError(f"{path} has no {name}: it is from another version; "
                                     f"{BUILD_HINT}") from None
        fn.restype = restype
        fn.argtypes = argtypes
    return lib


def _names(fn) -> tuple[str, ...]:
    out = []
    while (name := fn(len(out))) is not None:
        out.append(name.decode())
    return tuple(out)


@cache
def stats_fields() -> tuple[str, ...]:
    """The STATS counter names of the C++ side, in wire order."""
    return _names(load().ftd_stats_field)


@cache
def constants() -> dict[str, int]:
    """Every constant the C++ side exports (protocol limits, message ids, frame sizes...)."""
    lib = load()
    value = ctypes.c_int64()
    out = {}
    for name in _names(lib.ftd_constant_name):
        if lib.ftd_constant(name.encode(), ctypes.byref(value)) != 0:
            raise DeviceLibraryError(f"constant {name} listed but not found")
        out[name] = value.value
    return out
