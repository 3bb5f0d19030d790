# SPDX-License-Identifier: GPL-3.0-or-later
"""Every firmware build's Intel HEX (firmware/hex.cmake) against its ELF: valid records, the
same bytes as the ELF's .text + .data, inside the MCU's application area
(python/ax12_fuses.py), and an -eeprom.hex exactly when the ELF has an .eeprom section.
The merged HEX of each part whose application sits beside the bootloader (cmake/firmware.cmake,
scripts/ax12_merge_hex.py): the same application bytes, a valid application record, the
bootloader's bytes in the boot section; the merge script on its own, with a stand-in
bootloader HEX; the bootloader's HEX inside the 512 B boot section on both parts; and the
parts with a bootloader the same in the build (firmware/bootable_mcus.cmake) and in
python/ax12_fuses.py."""

import os
import subprocess
import sys

import pytest
from intelhex import IntelHex

import ax12_app_image
import ax12_fuses

FIRMWARE_DIR = os.environ.get("AX12_FIRMWARE_DIR") or os.path.join(
    os.path.dirname(__file__), "..", "..", "build", "firmware")
OBJCOPY = os.environ.get("AX12_OBJCOPY") or "avr-objcopy"
BUILDS = [(profile, mcu) for mcu in ax12_fuses.MCUS for profile in ("ax12", "ax12a")]
REPO = os.path.join(os.path.dirname(__file__), "..", "..")
MERGE = os.path.join(REPO, "scripts", "ax12_merge_hex.py")
BOOT_HEX_328P = os.path.join(FIRMWARE_DIR, "ax12-boot-atmega328p.hex")


def paths(profile, mcu):
    stem = os.path.join(FIRMWARE_DIR, f"ax12-{profile}-{mcu}")
    return stem + ".elf", stem + ".hex", stem + "-eeprom.hex"


def elf_bytes(elf, tmp_path, sections):
    out = tmp_path / "image.bin"
    command = [OBJCOPY, "-O", "binary"]
    for section in sections:
        command += ["-j", section]
    if sections == [".eeprom"]:
        command += ["--set-section-flags=.eeprom=alloc,load", "--change-section-lma", ".eeprom=0"]
    subprocess.run(command + [elf, str(out)], check=True)
    return out.read_bytes()


def section_sizes(elf):
    listing = subprocess.run([OBJCOPY.replace("objcopy", "size"), "-A", elf],
                             check=True, capture_output=True, text=True).stdout
    sizes = {}
    for line in listing.splitlines():
        words = line.split()
        if len(words) >= 2 and words[0].startswith(".") and words[1].isdigit():
            sizes[words[0]] = int(words[1])
    return sizes


def check_records(path, start=None):
    """Every line a record with a valid checksum, data and end-of-file records only (16-bit
    addresses suffice below 64 KB), the end-of-file record last; and, with start, one start
    address record (type 03) of that byte address (the bootloader's: where BOOTRST starts)."""
    lines = open(path).read().splitlines()
    assert lines, f"{path} is empty"
    for number, line in enumerate(lines, 1):
        assert line.startswith(":"), f"{path}:{number}: not a record"
        raw = bytes.fromhex(line[1:])
        assert len(raw) == raw[0] + 5, f"{path}:{number}: length byte disagrees with the record"
        assert sum(raw) % 256 == 0, f"{path}:{number}: bad checksum"
        kind = raw[3]
        if kind == 0x03 and start is not None:
            assert int.from_bytes(raw[4:8], "big") == start, f"{path}:{number}: start address"
            continue
        assert kind in (0x00, 0x01), f"{path}:{number}: record type {kind:02X}"
        assert (kind == 0x01) == (number == len(lines)), f"{path}:{number}: end-of-file record misplaced"


@pytest.mark.parametrize("profile,mcu", BUILDS)
def test_hex_is_the_elf_flash_image(profile, mcu, tmp_path):
    elf, hex_path, _ = paths(profile, mcu)
    assert os.path.isfile(hex_path), f"{hex_path} missing: the build writes it beside the ELF"
    assert os.path.getmtime(hex_path) >= os.path.getmtime(elf), f"{hex_path} is older than its ELF"
    check_records(hex_path)
    image = IntelHex(hex_path)
    expected = elf_bytes(elf, tmp_path, [".text", ".data"])
    sizes = section_sizes(elf)
    assert len(expected) == sizes[".text"] + sizes.get(".data", 0)
    assert image.minaddr() == 0
    assert len(image) == len(expected), "the HEX holds bytes outside .text + .data"
    assert image.tobinstr(start=0, size=len(expected)) == expected
    limit = ax12_fuses.MCUS[mcu].app_limit_bytes
    assert image.maxaddr() < limit, f"{hex_path} ends at 0x{image.maxaddr():04X}, past the application area"


@pytest.mark.parametrize("profile,mcu", BUILDS)
def test_eeprom_hex_only_with_an_eeprom_section(profile, mcu, tmp_path):
    elf, _, eeprom_hex = paths(profile, mcu)
    if section_sizes(elf).get(".eeprom", 0) == 0:
        assert not os.path.exists(eeprom_hex), f"{eeprom_hex} written for an ELF without .eeprom"
        return
    check_records(eeprom_hex)
    expected = elf_bytes(elf, tmp_path, [".eeprom"])
    image = IntelHex(eeprom_hex)
    assert image.minaddr() == 0
    assert image.tobinstr(start=0, size=len(expected)) == expected


def check_merged(merged_path, app_hex_path, boot_hex_path, app_bytes=None, mcu="atmega328p"):
    """merged_path holds the application HEX's bytes unchanged (app_bytes too, when given),
    a record whose last address and check value are those of the flash below it, and the
    bootloader's bytes in the boot section, and nothing else."""
    part = ax12_fuses.MCUS[mcu]
    check_records(merged_path)
    merged, app, boot = IntelHex(merged_path), IntelHex(app_hex_path), IntelHex(boot_hex_path)
    app_data = app.tobinstr(start=0, size=len(app))
    if app_bytes is not None:
        assert app_data == app_bytes
    assert merged.tobinstr(start=0, size=len(app_data)) == app_data
    record = merged.tobinstr(start=part.record_at, size=ax12_fuses.RECORD_BYTES)
    last, check = int.from_bytes(record[:2], "little"), int.from_bytes(record[2:], "little")
    assert last + 1 == len(app_data)
    assert check == ax12_app_image.check_value(merged.tobinstr(start=0, size=last + 1)), "the flash's check value"
    assert boot.minaddr() >= part.boot_start
    assert merged.tobinstr(start=boot.minaddr(), end=boot.maxaddr()) == boot.tobinstr(start=boot.minaddr(),
                                                                                       end=boot.maxaddr())
    expected = set(app.addresses()) | set(range(part.record_at, part.boot_start)) | set(boot.addresses())
    assert set(merged.addresses()) == expected, "bytes outside application, record and bootloader"


@pytest.mark.parametrize("mcu", sorted(ax12_fuses.MCUS))
def test_the_bootloader_hex_fits_the_boot_section(mcu):
    part = ax12_fuses.MCUS[mcu]
    path = os.path.join(FIRMWARE_DIR, f"ax12-boot-{mcu}.hex")
    check_records(path, start=part.boot_start)
    boot = IntelHex(path)
    assert boot.minaddr() == part.boot_start and boot.maxaddr() < part.flash_bytes
    assert part.boot_start == part.flash_bytes - 512


def test_the_parts_with_a_bootloader_agree():
    text = open(os.path.join(REPO, "firmware", "bootable_mcus.cmake")).read()
    listed = [line for line in text.splitlines() if line.startswith("set(AX12_BOOTABLE_MCUS")]
    assert len(listed) == 1
    assert set(listed[0][len("set(AX12_BOOTABLE_MCUS"):].strip(" )").split()) == ax12_fuses.BOOTLOADER_MCUS


@pytest.mark.parametrize("profile", ["ax12", "ax12a"])
def test_merged_hex_is_application_record_and_bootloader(profile, tmp_path):
    if not os.path.exists(BOOT_HEX_328P):
        pytest.skip(f"{BOOT_HEX_328P} not built (the bootloader): no merged HEX")
    elf, app_hex, _ = paths(profile, "atmega328p")
    merged = os.path.join(FIRMWARE_DIR, f"ax12-{profile}-atmega328p-merged.hex")
    assert os.path.isfile(merged), f"{merged} missing: the build writes it beside the HEX"
    check_merged(merged, app_hex, BOOT_HEX_328P, elf_bytes(elf, tmp_path, [".text", ".data"]))


def merge(*args):
    return subprocess.run([sys.executable, MERGE, "--mcu", "atmega328p", *args],
                          capture_output=True, text=True, timeout=60)


def stand_in_bootloader(path, first=0x7E00, size=500):
    boot = IntelHex()
    boot.frombytes(bytes((7 * i) & 0xFF for i in range(size)), offset=first)
    boot.write_hex_file(str(path))
    return str(path)


def test_merge_script_with_a_stand_in_bootloader(tmp_path):
    _, app_hex, _ = paths("ax12a", "atmega328p")
    boot = stand_in_bootloader(tmp_path / "boot.hex")
    out = tmp_path / "merged.hex"
    run = merge(app_hex, boot, str(out))
    assert run.returncode == 0, run.stderr
    check_merged(str(out), app_hex, boot)
    written = out.stat().st_mtime_ns
    assert merge(app_hex, boot, str(out)).returncode == 0
    assert out.stat().st_mtime_ns == written, "the same bytes are not written again"


def test_merge_script_without_a_bootloader_writes_nothing(tmp_path):
    _, app_hex, _ = paths("ax12", "atmega328p")
    out = tmp_path / "merged.hex"
    out.write_text("stale")
    run = merge(app_hex, str(tmp_path / "no-boot.hex"), str(out))
    assert run.returncode == 0 and "not built" in run.stderr
    assert not out.exists(), "a stale merged HEX is removed"


@pytest.mark.parametrize("app_profile_mcu,boot_first,message", [
    (("ax12", "atmega88"), 0x7E00, "built for the atmega88"),
    (("ax12", "atmega328p"), 0x7D00, "must lie in the boot section"),
])
def test_merge_script_refuses(tmp_path, app_profile_mcu, boot_first, message):
    _, app_hex, _ = paths(*app_profile_mcu)
    boot = stand_in_bootloader(tmp_path / "boot.hex", first=boot_first)
    run = merge(app_hex, boot, str(tmp_path / "merged.hex"))
    assert run.returncode == 2 and message in run.stderr, run.stderr
    assert not (tmp_path / "merged.hex").exists()
