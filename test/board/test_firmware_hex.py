# SPDX-License-Identifier: GPL-3.0-or-later
"""Every firmware build's Intel HEX (firmware/hex.cmake) against its ELF: valid records, the
same bytes as the ELF's .text + .data, inside the MCU's application area
(python/ax12_fuses.py), and an -eeprom.hex exactly when the ELF has an .eeprom section."""

import os
import subprocess

import pytest
from intelhex import IntelHex

import ax12_fuses

FIRMWARE_DIR = os.environ.get("AX12_FIRMWARE_DIR") or os.path.join(
    os.path.dirname(__file__), "..", "..", "build", "firmware")
OBJCOPY = os.environ.get("AX12_OBJCOPY") or "avr-objcopy"
BUILDS = [(profile, mcu) for mcu in ax12_fuses.MCUS for profile in ("ax12", "ax12a")]


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


def check_records(path):
    """Every line a record with a valid checksum, data and end-of-file records only (16-bit
    addresses suffice below 64 KB), the end-of-file record last."""
    lines = open(path).read().splitlines()
    assert lines, f"{path} is empty"
    for number, line in enumerate(lines, 1):
        assert line.startswith(":"), f"{path}:{number}: not a record"
        raw = bytes.fromhex(line[1:])
        assert len(raw) == raw[0] + 5, f"{path}:{number}: length byte disagrees with the record"
        assert sum(raw) % 256 == 0, f"{path}:{number}: bad checksum"
        kind = raw[3]
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
