"""`fingertip flash`: the avrdude command line, and real avrdude runs on the built HEX.

No Uno is needed: the upload test runs the real avrdude with its ``arduino`` programmer
against an emulated optiboot bootloader (STK500 v1) on a pty, then compares the emulated
flash with the HEX byte for byte.
"""
from __future__ import annotations

import os
import select
import shutil
import subprocess
import sys
import threading
import tty
from pathlib import Path

import pytest

from fingertip.flash import (
    FLASH_LIMIT,
    FlashError,
    avrdude_argv,
    default_hex,
    flash,
    has_dryrun,
    parse_avrdude_output,
    read_ihex,
)

ROOT = Path(__file__).resolve().parents[2]
EXE = Path(sys.executable).with_name("fingertip")
HAVE_AVRDUDE = shutil.which("avrdude") is not None
needs_avrdude = pytest.mark.skipif(not HAVE_AVRDUDE, reason="avrdude is not installed")


@pytest.fixture(scope="session")
def built() -> dict[int, Path]:
    """The HEX files of `make -C firmware all` (built here if missing)."""
    hexes = {n: default_hex(n, ROOT) for n in (4, 16)}
    if not all(p.is_file() for p in hexes.values()):
        if shutil.which("avr-gcc") is None:
            pytest.skip("avr-gcc is not installed: cannot build the firmware")
        subprocess.run(["make", "--no-print-directory", "-C", str(ROOT / "firmware"), "all"],
                       check=True, capture_output=True)
    return hexes


def flash_size(elf: Path) -> int:
    """.text + .data of an ELF, as avr-size reports them: what goes into the flash."""
    out = subprocess.run(["avr-size", "-A", str(elf)], check=True, capture_output=True,
                         text=True).stdout
    sections = {f[0]: int(f[1]) for f in (line.split() for line in out.splitlines())
                if len(f) >= 2 and f[0].startswith(".") and f[1].isdigit()}
    return sections[".text"] + sections[".data"]


class Optiboot:
    """Enough of optiboot's STK500 v1 dialect for avrdude's ``arduino`` programmer to write
    and verify the flash, on the master side of a pty."""

    def __init__(self, signature: bytes = b"\x1e\x95\x0f") -> None:
        self.master, self.slave = os.openpty()
        tty.setraw(self.master)
        self.port = os.ttyname(self.slave)
        self.signature = signature
        self.flash = bytearray(b"\xff" * 32768)
        self.pages_written = 0
        self._addr = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)

    def __enter__(self) -> Optiboot:
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        os.close(self.master)
        os.close(self.slave)

    def _read(self, n: int) -> bytes:
        out = b""
        while len(out) < n:
            if self._stop.is_set():
                raise EOFError
            ready, _, _ = select.select([self.master], [], [], 0.1)
            if ready:
                try:
                    chunk = os.read(self.master, n - len(out))
                except OSError as e:  # the other side went away
                    raise EOFError from e
                out += chunk
        return out

    def _reply(self, payload: bytes = b"") -> None:
        if self._read(1) == b"\x20":  # CRC_EOP; otherwise out of sync: stay silent
            os.write(self.master, b"\x14" + payload + b"\x10")  # INSYNC ... OK

    def _serve(self) -> None:
        try:
            while True:
                cmd = self._read(1)[0]
                if cmd == 0x41:  # GET_PARAMETER
                    self._read(1)
                    self._reply(b"\x04")
                elif cmd == 0x42:  # SET_DEVICE
                    self._read(20)
                    self._reply()
                elif cmd == 0x45:  # SET_DEVICE_EXT
                    self._read(5)
                    self._reply()
                elif cmd == 0x55:  # LOAD_ADDRESS (word address)
                    a = self._read(2)
                    self._addr = (a[0] | a[1] << 8) * 2
                    self._reply()
                elif cmd == 0x56:  # UNIVERSAL
                    self._read(4)
                    self._reply(b"\x00")
                elif cmd == 0x64:  # PROG_PAGE
                    h = self._read(3)
                    n = h[0] << 8 | h[1]
                    data = self._read(n)
                    if h[2] == ord("F"):
                        self.flash[self._addr:self._addr + n] = data
                        self.pages_written += 1
                    self._reply()
                elif cmd == 0x74:  # READ_PAGE
                    h = self._read(3)
                    n = h[0] << 8 | h[1]
                    self._reply(bytes(self.flash[self._addr:self._addr + n]))
                elif cmd == 0x75:  # READ_SIGN
                    self._reply(self.signature)
                else:  # GET_SYNC, ENTER/LEAVE_PROGMODE and the rest: just in sync
                    self._reply()
        except EOFError:
            pass


def run_cli(*args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([str(EXE), *args], capture_output=True, text=True, timeout=120,
                          env=env)


# --- the command line, pure ------------------------------------------------------------------

def test_argv_for_an_uno():
    assert avrdude_argv("/x/fw.hex", "/dev/ttyACM0") == [
        "avrdude", "-c", "arduino", "-p", "atmega328p", "-P", "/dev/ttyACM0", "-b", "115200",
        "-D", "-U", "flash:w:/x/fw.hex:i"]
    assert avrdude_argv(Path("a.hex"), "COM3", avrdude="/opt/avrdude", baud=57600,
                        verify=False) == [
        "/opt/avrdude", "-c", "arduino", "-p", "atmega328p", "-P", "COM3", "-b", "57600", "-D",
        "-V", "-U", "flash:w:a.hex:i"]


def test_argv_for_a_dry_run_has_no_port_or_baud():
    assert avrdude_argv("fw.hex", None, programmer="dryrun") == [
        "avrdude", "-c", "dryrun", "-p", "atmega328p", "-D", "-U", "flash:w:fw.hex:i"]


def test_parse_avrdude_output():
    text = ("avrdude: writing 9460 bytes flash ...\navrdude: 9460 bytes of flash written\n"
            "avrdude: 9460 bytes of flash verified\n")
    assert parse_avrdude_output(text) == (9460, 9460)
    assert parse_avrdude_output("avrdude: 12 bytes of flash written\n") == (12, None)
    assert parse_avrdude_output("") == (None, None)


def test_read_ihex(tmp_path):
    f = tmp_path / "x.hex"
    f.write_text(":0400000001020304F2\n:02000004000AF0\n:0100000005FA\n:00000001FF\n")
    assert read_ihex(f) == {0: 1, 1: 2, 2: 3, 3: 4, 0xA0000: 5}
    f.write_text(":0400000001020304F3\n:00000001FF\n")
    with pytest.raises(ValueError, match="checksum"):
        read_ihex(f)
    f.write_text(":0400000001020304F2\n")
    with pytest.raises(ValueError, match="end-of-file"):
        read_ihex(f)
    f.write_text("hello\n")
    with pytest.raises(ValueError, match="not an Intel HEX"):
        read_ihex(f)


def test_built_hex_matches_the_elf(built):
    for n, hex_path in built.items():
        image = read_ihex(hex_path)
        assert len(image) == max(image) + 1  # one contiguous block from address 0
        assert len(image) == flash_size(hex_path.with_suffix(".elf"))
        assert len(image) <= (12288 if n == 4 else FLASH_LIMIT)


# --- real avrdude ----------------------------------------------------------------------------

@needs_avrdude
@pytest.mark.parametrize("channels", [4, 16])
def test_upload_through_emulated_bootloader(built, channels):
    hex_path = built[channels]
    image = read_ihex(hex_path)
    with Optiboot() as boot:
        r = flash(boot.port, channels)
    assert r.ran and r.hex_path == hex_path
    assert r.bytes_written == r.bytes_verified == r.hex_bytes == len(image)
    assert r.argv[1:3] == ["-c", "arduino"]
    assert bytes(boot.flash[:len(image)]) == bytes(image[a] for a in range(len(image)))
    assert boot.pages_written == -(-len(image) // 128)  # 128-byte pages of the ATmega328P


@needs_avrdude
def test_cli_flash(built):
    with Optiboot() as boot:
        r = run_cli("flash", "--port", boot.port, "--channels", "4")
    assert r.returncode == 0, r.stderr
    n = len(read_ihex(built[4]))
    assert f"{n} bytes written, {n} verified" in r.stdout


@needs_avrdude
def test_avrdude_failure_is_reported(built):
    with Optiboot(signature=b"\x1e\x95\x14") as boot:  # an ATmega328 (not P): refused
        with pytest.raises(FlashError) as e:
            flash(boot.port, 4)
    assert e.value.code == 1
    assert "avrdude failed" in str(e.value) and "signature" in str(e.value).lower()


@needs_avrdude
@pytest.mark.skipif(HAVE_AVRDUDE and not has_dryrun("avrdude"),
                    reason="this avrdude has no dryrun programmer (added in avrdude 7.2)")
def test_dry_run_with_avrdude_dryrun_programmer(built):
    r = flash(None, 4, dry_run=True)
    assert r.ran and "dryrun" in r.argv
    assert r.bytes_written == len(read_ihex(built[4]))


@needs_avrdude
def test_dry_run_without_the_dryrun_programmer_checks_the_hex(built, tmp_path):
    # An avrdude that answers `-c ?` without listing dryrun, as 7.1 does.
    fake = tmp_path / "avrdude"
    fake.write_text("#!/bin/sh\necho 'Valid programmers are:' >&2\n"
                    "echo '  arduino = Arduino' >&2\nexit 1\n")
    fake.chmod(0o755)
    r = flash(None, 4, dry_run=True, avrdude=str(fake))
    assert not r.ran and r.bytes_written is None
    assert r.hex_bytes == len(read_ihex(built[4]))
    assert r.argv[:5] == [str(fake), "-c", "arduino", "-p", "atmega328p"]


def test_dry_run_with_a_dryrun_capable_avrdude(built, tmp_path):
    # Stand-in for avrdude >= 7.2: lists dryrun, records its arguments, reports the bytes.
    log = tmp_path / "argv"
    n = len(read_ihex(built[16]))
    fake = tmp_path / "avrdude"
    fake.write_text(
        "#!/bin/sh\n"
        'if [ "$2" = "?" ]; then echo "  dryrun = Dryrun programmer" >&2; exit 1; fi\n'
        f'echo "$@" > {log}\n'
        f'echo "avrdude: {n} bytes of flash written" >&2\n'
        f'echo "avrdude: {n} bytes of flash verified" >&2\n')
    fake.chmod(0o755)
    r = flash("/dev/ignored", 16, dry_run=True, avrdude=str(fake))
    assert r.ran and r.bytes_written == r.bytes_verified == n
    assert log.read_text().split() == [
        "-c", "dryrun", "-p", "atmega328p", "-D", "-U", f"flash:w:{built[16]}:i"]


# --- errors ----------------------------------------------------------------------------------

def test_missing_avrdude(tmp_path):
    with pytest.raises(FlashError, match="avrdude not found.*apt-get install avrdude") as e:
        flash("/dev/ttyACM0", 4, avrdude="avrdude-that-does-not-exist")
    assert e.value.code == 2
    r = run_cli("flash", "--port", "/dev/ttyACM0", env={**os.environ, "PATH": str(tmp_path)})
    assert r.returncode == 2 and "avrdude not found" in r.stderr


@needs_avrdude
def test_missing_port(built):
    with pytest.raises(FlashError, match="does not exist"):
        flash("/dev/ttyACM-not-there", 4)
    with pytest.raises(FlashError, match="no serial port"):
        flash(None, 4)
    r = run_cli("flash")
    assert r.returncode == 2 and "--port" in r.stderr
    r = run_cli("flash", "--port", "/dev/ttyACM-not-there")
    assert r.returncode == 2 and "does not exist" in r.stderr


@needs_avrdude
def test_missing_or_bad_hex(tmp_path):
    with pytest.raises(FlashError, match="no HEX file at"):
        flash("/dev/null", 4, tmp_path / "nope.hex")
    bad = tmp_path / "bad.hex"
    bad.write_text(":0400000001020304F3\n:00000001FF\n")
    with pytest.raises(FlashError, match="checksum"):
        flash("/dev/null", 4, bad)
    big = tmp_path / "big.hex"
    big.write_text(":02000004000AF0\n:0100000005FA\n:00000001FF\n")  # at 0xA0000
    with pytest.raises(FlashError, match="beyond the 32256 bytes"):
        flash("/dev/null", 4, big)
    r = run_cli("flash", "--port", "/dev/null", "--hex", str(tmp_path / "nope.hex"))
    assert r.returncode == 2 and "no HEX file" in r.stderr


@needs_avrdude
def test_missing_hex_is_built_when_the_repository_is_there(built, tmp_path):
    # A stand-in checkout whose `make -C firmware all` produces the HEX.
    fw = tmp_path / "firmware"
    fw.mkdir()
    (fw / "Makefile").write_text(
        f"all:\n\tmkdir -p build/fw4\n\tcp {built[4]} build/fw4/fingertip.hex\n")
    r = flash(None, 4, dry_run=True, root=tmp_path)
    assert r.hex_path == fw / "build" / "fw4" / "fingertip.hex"
    assert r.hex_path.read_bytes() == built[4].read_bytes()
    # A build that fails is reported with make's output.
    (fw / "build" / "fw4" / "fingertip.hex").unlink()
    (fw / "Makefile").write_text("all:\n\t@echo 'avr-gcc: no such thing' >&2; exit 3\n")
    with pytest.raises(FlashError, match="building the firmware failed(.|\n)*no such thing"):
        flash(None, 4, dry_run=True, root=tmp_path)


@needs_avrdude
def test_missing_hex_without_a_repository(tmp_path, monkeypatch):
    monkeypatch.setattr("fingertip.flash.repo_root", lambda: None)
    with pytest.raises(FlashError, match="no source checkout"):
        flash("/dev/null", 4)
