"""Upload the Uno firmware with avrdude, without PlatformIO.

The pure part, :func:`avrdude_argv`, builds the command line (Arduino Uno: ATmega328P behind
the optiboot bootloader, avrdude's ``arduino`` programmer at 115200 baud, ``-D`` because the
bootloader erases page by page). :func:`flash` resolves avrdude and the HEX (building it with
``make -C firmware all`` when it is missing and the repository is there), checks the HEX,
runs avrdude and reports what it wrote, or raises :class:`FlashError` with a message a user
can act on.
"""
from __future__ import annotations

import logging
import os
import re
import shutil
import subprocess
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from .errors import DeviceError

log = logging.getLogger(__name__)

MCU = "atmega328p"
PROGRAMMER = "arduino"
DRYRUN_PROGRAMMER = "dryrun"
DEFAULT_BAUD = 115200
FLASH_LIMIT = 32256
"""Application flash of an Uno: 32 KB less the 512 B optiboot bootloader."""
CHANNEL_BUILDS = {4: "fw4", 16: "fw16"}

Runner = Callable[..., subprocess.CompletedProcess]


class FlashError(DeviceError):
    """Flashing cannot proceed or failed; ``code`` (= ``exit_code``) is the exit status for
    the command line (2: set-up problem such as a missing tool, port or file; 1: avrdude
    failed)."""

    def __init__(self, message: str, code: int = 2) -> None:
        super().__init__(message, exit_code=code)
        self.code = code


@dataclass
class FlashResult:
    argv: list[str]
    hex_path: Path
    hex_bytes: int
    """Data bytes in the HEX file."""
    ran: bool = True
    """False for a dry run that avrdude could not do (no ``dryrun`` programmer)."""
    bytes_written: int | None = None
    bytes_verified: int | None = None
    output: str = field(default="", repr=False)


# --- pure helpers ----------------------------------------------------------------------------

def avrdude_argv(hex_path: str | os.PathLike, port: str | None, *, avrdude: str = "avrdude",
                 programmer: str = PROGRAMMER, baud: int = DEFAULT_BAUD, mcu: str = MCU,
                 verify: bool = True) -> list[str]:
    """The avrdude command line that writes ``hex_path`` to the flash of an Uno on ``port``."""
    argv = [avrdude, "-c", programmer, "-p", mcu]
    if port:
        argv += ["-P", port]
    if programmer != DRYRUN_PROGRAMMER:
        argv += ["-b", str(baud)]
    argv.append("-D")  # no chip erase: optiboot erases each page as it writes it
    if not verify:
        argv.append("-V")
    argv += ["-U", f"flash:w:{os.fspath(hex_path)}:i"]
    return argv


def read_ihex(path: str | os.PathLike) -> dict[int, int]:
    """Intel HEX -> {address: byte}. Raises ValueError on a malformed file."""
    mem: dict[int, int] = {}
    base = 0
    text = Path(path).read_text(encoding="ascii", errors="replace")
    for n, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line:
            continue
        if not line.startswith(":") or len(line) < 11 or len(line) % 2 == 0:
            raise ValueError(f"{path}:{n}: not an Intel HEX record")
        try:
            rec = bytes.fromhex(line[1:])
        except ValueError as e:
            raise ValueError(f"{path}:{n}: not an Intel HEX record") from e
        count, addr, kind = rec[0], rec[1] << 8 | rec[2], rec[3]
        if len(rec) != count + 5:
            raise ValueError(f"{path}:{n}: record length does not match its byte count")
        if sum(rec) & 0xFF:
            raise ValueError(f"{path}:{n}: checksum error")
        data = rec[4:4 + count]
        if kind == 0:
            for i, b in enumerate(data):
                mem[base + addr + i] = b
        elif kind == 1:
            return mem
        elif kind == 2:
            base = (data[0] << 8 | data[1]) << 4
        elif kind == 4:
            base = (data[0] << 8 | data[1]) << 16
        elif kind not in (3, 5):
            raise ValueError(f"{path}:{n}: unknown record type {kind}")
    raise ValueError(f"{path}: no end-of-file record")


def parse_avrdude_output(text: str) -> tuple[int | None, int | None]:
    """Bytes written and verified, as avrdude reports them (None when not reported)."""
    def last(pattern: str) -> int | None:
        found = re.findall(pattern, text)
        return int(found[-1]) if found else None
    return (last(r"(\d+) bytes of flash written"), last(r"(\d+) bytes of flash verified"))


def repo_root() -> Path | None:
    """The source checkout this package runs from (editable install), or None."""
    root = Path(__file__).resolve().parents[2]
    return root if (root / "firmware" / "Makefile").is_file() else None


def default_hex(channels: int, root: Path | None = None) -> Path | None:
    """Where ``make -C firmware all`` puts the HEX of a channel count."""
    root = root or repo_root()
    if root is None:
        return None
    return root / "firmware" / "build" / CHANNEL_BUILDS[channels] / "fingertip.hex"


def has_dryrun(avrdude: str, run: Runner = subprocess.run) -> bool:
    """Whether this avrdude has the ``dryrun`` programmer (avrdude 7.2 and later)."""
    try:
        r = run([avrdude, "-c", "?"], capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return False
    return re.search(r"^\s*dryrun\s", r.stdout + r.stderr, re.MULTILINE) is not None


# --- the runner ------------------------------------------------------------------------------

def _find_avrdude(avrdude: str) -> str:
    found = shutil.which(avrdude)
    if not found:
        raise FlashError(f"avrdude not found ({avrdude!r} is not on PATH): install it "
                         "(Debian/Ubuntu: sudo apt-get install avrdude)")
    return found


def _resolve_hex(channels: int, hex_path: str | os.PathLike | None, root: Path | None,
                 run: Runner) -> Path:
    if hex_path is not None:
        path = Path(hex_path)
        if not path.is_file():
            raise FlashError(f"no HEX file at {path}")
        return path
    if channels not in CHANNEL_BUILDS:
        raise FlashError(f"no firmware build for {channels} channels "
                         f"(choose {' or '.join(map(str, CHANNEL_BUILDS))})")
    root = root or repo_root()
    path = default_hex(channels, root)
    if path is not None and path.is_file():
        return path
    if root is None or path is None:
        raise FlashError("no HEX file given and no source checkout to build one from: "
                         "pass --hex PATH (a fingertip.hex built with `make firmware`)")
    make = shutil.which("make")
    if not make:
        raise FlashError(f"{path} is missing and `make` is not installed to build it "
                         "(sudo apt-get install make), or pass --hex PATH")
    cmd = [make, "--no-print-directory", "-C", str(root / "firmware"), "all"]
    log.warning("%s is missing: building it with %s", path, " ".join(cmd))
    try:
        r = run(cmd, capture_output=True, text=True)
    except OSError as e:
        raise FlashError(f"cannot run make: {e}") from e
    if r.returncode != 0 or not path.is_file():
        tail = "\n".join((r.stdout + r.stderr).strip().splitlines()[-15:])
        # the command line's error is one line: make's own lines go to the log in full
        log.warning("make's last lines:\n%s", tail)
        raise FlashError(f"building the firmware failed ({' '.join(cmd)}):\n{tail}")
    return path


def flash(port: str | None, channels: int = 4, hex_path: str | os.PathLike | None = None, *,
          dry_run: bool = False, baud: int = DEFAULT_BAUD, avrdude: str = "avrdude",
          root: Path | None = None, run: Runner = subprocess.run,
          extra_args: Sequence[str] = ()) -> FlashResult:
    """Write the firmware to the Uno on ``port`` (see the module docstring)."""
    exe = _find_avrdude(avrdude)
    path = _resolve_hex(channels, hex_path, root, run)
    try:
        image = read_ihex(path)
    except (OSError, ValueError) as e:
        raise FlashError(f"cannot use {path}: {e}") from e
    if not image:
        raise FlashError(f"{path} holds no data")
    end = max(image) + 1
    if end > FLASH_LIMIT:
        raise FlashError(f"{path} reaches address {end}, beyond the {FLASH_LIMIT} bytes an "
                         "Uno has for the application (the bootloader sits above)")

    if dry_run:
        if not has_dryrun(exe, run):
            argv = avrdude_argv(path, port, avrdude=exe, baud=baud)
            log.info("this avrdude has no 'dryrun' programmer (avrdude >= 7.2 has it): "
                        "checked the HEX only; would run: %s", " ".join(argv))
            return FlashResult(argv, path, len(image), ran=False)
        # The dryrun programmer emulates a part in memory: no port, nothing is opened.
        argv = avrdude_argv(path, None, avrdude=exe, programmer=DRYRUN_PROGRAMMER)
    else:
        if not port:
            raise FlashError("no serial port: pass --port (e.g. /dev/ttyACM0)")
        if not os.path.exists(port):
            raise FlashError(f"serial port {port} does not exist (is the Uno plugged in? "
                             "`ls /dev/ttyACM* /dev/ttyUSB*` lists candidates)")
        argv = avrdude_argv(path, port, avrdude=exe, baud=baud)
    argv += list(extra_args)
    log.info("running %s", " ".join(argv))
    try:
        r = run(argv, capture_output=True, text=True, timeout=300)
    except (OSError, subprocess.SubprocessError) as e:
        raise FlashError(f"cannot run avrdude: {e}") from e
    output = r.stdout + r.stderr
    written, verified = parse_avrdude_output(output)
    if r.returncode != 0:
        tail = "\n".join(line for line in output.strip().splitlines()[-12:])
        log.warning("avrdude's last lines:\n%s", tail)  # the error line is one line
        raise FlashError(f"avrdude failed (exit {r.returncode}):\n{tail}", code=1)
    return FlashResult(argv, path, len(image), ran=True, bytes_written=written,
                       bytes_verified=verified, output=output)
