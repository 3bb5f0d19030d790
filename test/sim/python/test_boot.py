# SPDX-License-Identifier: GPL-3.0-or-later
"""`ax12-emu serve --bootloader`: the flash a servo changes with SPM, kept in servo-<n>.flash.
The programs of test_boot_flash.c stand in for the firmware (AX12_BOOT_DIR): boot_spm.elf at
the boot section erases and writes the page at 0x1000 when it is blank, then turns its USART
receiver on, so `ready:` comes only after the write; boot_app_1.elf and boot_app_2.elf are two
builds of one application. Checks: a SIGKILL right after `ready:` leaves the written page in
the file (the end of the step of the write persisted it); the same build runs that flash again;
another build drops it with one line on stderr; the default bootloader of --firmware-dir (in
front of this project's application, not of another program); bad --bootloader input."""
import os
import shutil
import signal
import struct
import subprocess

import pytest

from conftest import EMU, Emulator

BOOT_DIR = os.environ.get("AX12_BOOT_DIR", "")
PROJECT_APP = os.path.join(os.environ.get("AX12_FIRMWARE_DIR", ""), "ax12-ax12-atmega328p.elf")
FLASH_BYTES = 32768
HEADER_BYTES = 24
TEST_PAGE = 0x1000
PATTERN = bytes(b for i in range(0, 128, 2) for b in (i, 0x5A))


def elf(name):
    path = os.path.join(BOOT_DIR, name)
    if not os.path.exists(path):
        pytest.fail(f"boot test program missing: {path} (AX12_BOOT_DIR)")
    return path


def serve(state_dir, app, *args):
    return Emulator(["--mcu", "atmega328p", "--elf", elf(app), "--fast", "--state-dir", str(state_dir),
                     "--control", os.path.join(str(state_dir), "c.sock")] + list(args))


def read_flash(path):
    with open(path, "rb") as f:
        data = f.read()
    assert len(data) == HEADER_BYTES + FLASH_BYTES
    assert data[:8] == b"AX12FLSH"
    assert struct.unpack_from("<II", data, 8) == (FLASH_BYTES, 1)
    return struct.unpack_from("<Q", data, 16)[0], data[HEADER_BYTES:]


def stderr_of(emu):
    return emu.proc.stderr.read().decode(errors="replace")


def test_the_flash_written_by_spm_survives_sigkill_and_is_dropped_for_another_build(tmp_path):
    flash_path = tmp_path / "servo-1.flash"
    emu = serve(tmp_path, "boot_app_1.elf", "--bootloader", elf("boot_spm.elf"))
    assert emu.kill() == -signal.SIGKILL
    identity, flash = read_flash(flash_path)
    assert flash[TEST_PAGE:TEST_PAGE + 128] == PATTERN
    # The record the emulator wrote below the boot section (0x7E00): the application's last
    # address and its check value (firmware/boot/boot_image.h).
    last = int.from_bytes(flash[0x7DFC:0x7DFE], "little")
    assert 0 < last < TEST_PAGE and flash[last + 1:TEST_PAGE] == b"\xff" * (TEST_PAGE - last - 1)
    sum1 = sum2 = 0
    for byte in flash[:last + 1]:
        sum1 = (sum1 + byte) & 0xFF
        sum2 = (sum2 + sum1) & 0xFF
    assert flash[0x7DFE:0x7E00] == bytes([sum1, sum2])

    emu = serve(tmp_path, "boot_app_1.elf", "--bootloader", elf("boot_spm.elf"))
    assert emu.stop() == 0
    assert f"servo 1 runs the flash it was updated to ({flash_path})" in stderr_of(emu)
    assert read_flash(flash_path) == (identity, flash)  # kept, unchanged: the page was found

    emu = serve(tmp_path, "boot_app_2.elf", "--bootloader", elf("boot_spm.elf"))
    assert emu.stop() == 0
    lines = [line for line in stderr_of(emu).splitlines() if "flashed image" in line]
    assert lines == [f"ax12-emu: the firmware was rebuilt: servo 1's flashed image is dropped ({flash_path} removed)"]
    new_identity, new_flash = read_flash(flash_path)  # written again by the program, for the new build
    assert new_identity != identity
    assert new_flash[TEST_PAGE:TEST_PAGE + 128] == PATTERN


def test_the_bootloader_of_the_firmware_dir_is_the_default(tmp_path):
    firmware_dir = tmp_path / "fw"
    firmware_dir.mkdir()
    shutil.copy(elf("boot_spm.elf"), firmware_dir / "ax12-boot-atmega328p.elf")
    shutil.copy(PROJECT_APP, firmware_dir / "ax12-ax12-atmega328p.elf")
    state = tmp_path / "state"
    # this project's application (the ELF of --firmware-dir): the bootloader goes in front
    emu = Emulator(["--mcu", "atmega328p", "--fast", "--state-dir", str(state), "--firmware-dir", str(firmware_dir),
                    "--control", os.path.join(str(state), "c.sock")])
    assert emu.stop() == 0
    said = stderr_of(emu)
    assert "(ax12, atmega328p, bootloader)" in said and "not this project's application" not in said, said

    # --bootloader none: the application alone, from address 0 (it never uses SPM).
    state = tmp_path / "none"
    emu = serve(state, "boot_app_1.elf", "--firmware-dir", str(firmware_dir), "--bootloader", "none")
    assert emu.stop() == 0
    assert not (state / "servo-1.flash").exists()

    # a program that is not this project's application runs alone too, and serve says so once
    state = tmp_path / "foreign"
    emu = serve(state, "boot_app_1.elf", "--firmware-dir", str(firmware_dir))
    assert emu.stop() == 0
    assert not (state / "servo-1.flash").exists()
    said = stderr_of(emu)
    assert "(ax12, atmega328p) on" in said, said
    assert said.count("is not this project's application: it runs without the bootloader") == 1, said
    assert said.count("has no .mmcu section: it runs as an atmega328p at 16 MHz") == 1, said

    # asked for, the bootloader goes in front of it
    state = tmp_path / "asked"
    emu = serve(state, "boot_app_1.elf", "--bootloader", str(firmware_dir / "ax12-boot-atmega328p.elf"))
    assert emu.stop() == 0
    said = stderr_of(emu)
    assert "(ax12, atmega328p, bootloader)" in said, said
    _, flash = read_flash(state / "servo-1.flash")
    assert flash[TEST_PAGE:TEST_PAGE + 128] == PATTERN


@pytest.mark.parametrize("bootloader, status, message", [
    ("missing.elf", 1, "bootloader ELF"),
    ("boot_app_2.elf", 1, "not at the boot section's start 0x7e00"),
    ("", 2, "empty --bootloader"),
])
def test_bad_bootloader_input_stops_before_ready(tmp_path, bootloader, status, message):
    path = os.path.join(BOOT_DIR, bootloader) if bootloader else ""
    proc = subprocess.run([EMU, "serve", "--mcu", "atmega328p", "--elf", elf("boot_app_1.elf"), "--fast",
                           "--state-dir", str(tmp_path), "--bootloader", path],
                          capture_output=True, timeout=20)
    assert proc.returncode == status
    assert proc.stdout == b""
    assert message in proc.stderr.decode()
    assert len(proc.stderr.decode().strip().splitlines()) == 1
