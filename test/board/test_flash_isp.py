# SPDX-License-Identifier: GPL-3.0-or-later
"""`scripts/ax12 flash-isp` (scripts/ax12_flash_isp.py): the avrdude command lines of both
MCUs (--dry-run), bad input refused before avrdude runs, the fuse bytes of
python/ax12_fuses.py against docs/hardware.md, and the parts' ids against avrdude's own
configuration."""

import os
import re
import shlex
import shutil
import subprocess

import pytest

import ax12_fuses

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
BUILD = os.path.abspath(os.environ.get("AX12_BUILD_DIR") or os.path.join(REPO, "build"))
FRONT_DOOR = os.path.join(REPO, "scripts", "ax12")

EXPECTED_FUSES = {  # application only: BOOTRST unprogrammed; a 512 B boot section on both
    "atmega88": {"lfuse": 0xD7, "hfuse": 0xD4, "efuse": 0xFD},   # BOOTSZ 10
    "atmega328p": {"lfuse": 0xD7, "hfuse": 0xD7, "efuse": 0xFC},  # BOOTSZ 11
}
EXPECTED_WITH_BOOT = {  # BOOTRST programmed
    "atmega88": {"lfuse": 0xD7, "hfuse": 0xD4, "efuse": 0xFC},
    "atmega328p": {"lfuse": 0xD7, "hfuse": 0xD6, "efuse": 0xFC},
}


def flash_isp(*args):
    return subprocess.run([FRONT_DOOR, "flash-isp", "--build", BUILD, *args],
                          capture_output=True, text=True, timeout=60)


def operations(command):
    words = shlex.split(command)
    return words, [words[i + 1] for i, word in enumerate(words) if word == "-U"]


def option(words, flag):
    return words[words.index(flag) + 1] if flag in words else None


@pytest.mark.parametrize("mcu,part", [("atmega88", "m88"), ("atmega328p", "m328p")])
@pytest.mark.parametrize("profile", ["ax12", "ax12a"])
def test_dry_run_command_line(mcu, part, profile):
    run = flash_isp("--programmer", "usbasp", "--port", "usb", "--mcu", mcu, "--profile", profile, "--dry-run")
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert len(lines) == 1, "the dry run prints exactly the command line"
    words, ops = operations(lines[0])
    assert os.path.basename(words[0]) == "avrdude"
    assert option(words, "-p") == part
    assert option(words, "-c") == "usbasp"
    assert option(words, "-P") == "usb"
    # A part with its bootloader (ax12_fuses.BOOTLOADER_MCUS): the merged HEX, BOOTRST programmed.
    boot = mcu in ax12_fuses.BOOTLOADER_MCUS
    hex_path = os.path.join(BUILD, "firmware", f"ax12-{profile}-{mcu}{'-merged' if boot else ''}.hex")
    fuses = (EXPECTED_WITH_BOOT if boot else EXPECTED_FUSES)[mcu]
    # Flash first (the part may still run on its 1 MHz internal clock), then the fuses.
    assert ops == [f"flash:w:{hex_path}:i"] + [f"{name}:w:0x{value:02X}:m" for name, value in fuses.items()]
    assert "-n" not in words and "-F" not in words and "-e" not in words


def test_defaults_and_other_hex(tmp_path):
    run = flash_isp("--programmer", "avrisp2", "--dry-run")
    words, ops = operations(run.stdout)
    assert option(words, "-p") == "m88" and "-P" not in words
    # the ATmega88 carries the bootloader: its whole flash, the merged HEX
    assert ops[0] == "flash:w:" + os.path.join(BUILD, "firmware", "ax12-ax12-atmega88-merged.hex") + ":i"
    own = tmp_path / "mine.hex"
    shutil.copy(os.path.join(BUILD, "firmware", "ax12-ax12a-atmega328p.hex"), own)
    run = flash_isp("--programmer", "avrisp2", "--mcu", "atmega328p", "--hex", str(own), "--dry-run")
    assert run.returncode == 0, run.stderr
    ops = operations(run.stdout)[1]
    assert ops[0] == f"flash:w:{own}:i"
    assert ops[2] == "hfuse:w:0xD7:m", "an application alone: BOOTRST unprogrammed"
    merged = tmp_path / "whole.hex"
    shutil.copy(os.path.join(BUILD, "firmware", "ax12-ax12a-atmega328p-merged.hex"), merged)
    run = flash_isp("--programmer", "avrisp2", "--mcu", "atmega328p", "--hex", str(merged), "--dry-run")
    assert run.returncode == 0, run.stderr
    assert operations(run.stdout)[1][2] == "hfuse:w:0xD6:m", "a whole flash with its bootloader: BOOTRST programmed"


def test_app_only_on_a_part_with_a_bootloader():
    run = flash_isp("--programmer", "usbasp", "--mcu", "atmega328p", "--app-only", "--dry-run")
    assert run.returncode == 0, run.stderr
    assert operations(run.stdout)[1] == ["flash:w:" + os.path.join(BUILD, "firmware", "ax12-ax12-atmega328p.hex") + ":i",
                                         "lfuse:w:0xD7:m", "hfuse:w:0xD7:m", "efuse:w:0xFC:m"]


def test_fuses_only():
    run = flash_isp("--programmer", "usbasp", "--mcu", "atmega328p", "--fuses-only", "--dry-run")
    assert run.returncode == 0, run.stderr
    words, ops = operations(run.stdout)
    assert ops == ["lfuse:w:0xD7:m", "hfuse:w:0xD6:m", "efuse:w:0xFC:m"]
    run = flash_isp("--programmer", "usbasp", "--mcu", "atmega328p", "--fuses-only", "--app-only", "--dry-run")
    assert operations(run.stdout)[1] == ["lfuse:w:0xD7:m", "hfuse:w:0xD7:m", "efuse:w:0xFC:m"]


def test_fuse_bytes():
    for mcu in ax12_fuses.MCUS:
        assert ax12_fuses.fuses(mcu) == EXPECTED_FUSES[mcu]
        assert ax12_fuses.fuses(mcu, bootloader=True) == EXPECTED_WITH_BOOT[mcu]
        fields = ax12_fuses.fuse_fields(mcu)
        high = fields["hfuse"]
        boot_size = fields["efuse" if mcu == "atmega88" else "hfuse"]["BOOTSZ"]
        assert boot_size == {"atmega88": 0b10, "atmega328p": 0b11}[mcu], "a 512 B boot section (256 words) on both"
        assert high["SPIEN"] == 0 and high["EESAVE"] == 0 and high["WDTON"] == 1
        assert high["RSTDISBL"] == 1 and high["DWEN"] == 1


def test_docs_give_the_same_fuses():
    """docs/hardware.md's fuse table: one row per MCU and state, bytes as in ax12_fuses."""
    text = open(os.path.join(REPO, "docs", "hardware.md")).read()
    rows = re.findall(r"^\| (atmega88|atmega328p) \| ([^|]+?) \| 0x([0-9A-F]{2}) \| 0x([0-9A-F]{2}) \| 0x([0-9A-F]{2}) \|",
                      text, re.M)
    found = {(mcu, "boot" in state): tuple(int(v, 16) for v in values) for mcu, state, *values in rows}
    for mcu in ax12_fuses.MCUS:
        for boot in (False, True):
            expected = ax12_fuses.fuses(mcu, boot)
            assert found.get((mcu, boot)) == (expected["lfuse"], expected["hfuse"], expected["efuse"]), (mcu, boot)


def refused(run, message):
    assert run.returncode != 0
    assert run.stdout == "", "nothing printed as a command line"
    assert message in run.stderr, run.stderr


def test_unknown_mcu():
    refused(flash_isp("--programmer", "usbasp", "--mcu", "atmega8", "--dry-run"), "invalid choice: 'atmega8'")


def test_missing_programmer():
    refused(flash_isp("--dry-run"), "--programmer")


def test_missing_hex(tmp_path):
    refused(flash_isp("--programmer", "usbasp", "--hex", str(tmp_path / "none.hex"), "--dry-run"),
            "no such HEX file")


def test_not_a_hex_file(tmp_path):
    text = tmp_path / "notes.hex"
    text.write_text("these are not records\n")
    refused(flash_isp("--programmer", "usbasp", "--hex", str(text), "--dry-run"), "is not an Intel HEX file")
    elf = os.path.join(BUILD, "firmware", "ax12-ax12-atmega88.elf")
    refused(flash_isp("--programmer", "usbasp", "--hex", elf, "--dry-run"), "is not an Intel HEX file")


def test_bad_checksum(tmp_path):
    lines = open(os.path.join(BUILD, "firmware", "ax12-ax12-atmega88.hex")).read().splitlines()
    last = lines[0][-2:]
    lines[0] = lines[0][:-2] + ("00" if last != "00" else "01")
    bad = tmp_path / "bad.hex"
    bad.write_text("\n".join(lines) + "\n")
    refused(flash_isp("--programmer", "usbasp", "--hex", str(bad), "--dry-run"), "is not an Intel HEX file")


@pytest.mark.parametrize("address", [0x7DFC, 0x7E00])
def test_image_past_the_application_area(tmp_path, address):
    # One data byte in the ATmega328P's application record (0x7DFC) or its boot section
    # (0x7E00): neither belongs to the application image.
    record = bytes([1, address >> 8, address & 0xFF, 0x00, 0xAA])
    line = ":" + (record + bytes([(-sum(record)) & 0xFF])).hex().upper()
    big = tmp_path / "big.hex"
    big.write_text(line + "\n:00000001FF\n")
    refused(flash_isp("--programmer", "usbasp", "--mcu", "atmega328p", "--hex", str(big), "--app-only", "--dry-run"),
            "outside the atmega328p's application area")
    if address >= 0x7E00:  # bytes in the boot section but no application from 0: no whole flash either
        refused(flash_isp("--programmer", "usbasp", "--mcu", "atmega328p", "--hex", str(big), "--dry-run"),
                "not a whole atmega328p flash with its bootloader")
    else:
        refused(flash_isp("--programmer", "usbasp", "--mcu", "atmega328p", "--hex", str(big), "--dry-run"),
                "outside the atmega328p's application area")


def test_hex_with_fuses_only_refused():
    hex_path = os.path.join(BUILD, "firmware", "ax12-ax12-atmega88.hex")
    refused(flash_isp("--programmer", "usbasp", "--hex", hex_path, "--fuses-only", "--dry-run"), "--fuses-only")


avrdude = shutil.which("avrdude")


@pytest.mark.skipif(avrdude is None, reason="avrdude not installed (scripts/setup)")
def test_unknown_programmer():
    refused(flash_isp("--programmer", "no-such-programmer", "--dry-run"), "knows no programmer")


@pytest.mark.skipif(avrdude is None, reason="avrdude not installed (scripts/setup)")
@pytest.mark.parametrize("mcu,signature", [("atmega88", "0x1e 0x93 0x0a"), ("atmega328p", "0x1e 0x95 0x0f")])
def test_avrdude_knows_the_part(mcu, signature):
    """avrdude's own configuration: the part id names the MCU (its signature), with the three
    fuse memories written."""
    part = ax12_fuses.MCUS[mcu].part
    listing = subprocess.run([avrdude, "-p", f"{part}/A"], capture_output=True, text=True, timeout=30)
    text = listing.stdout + listing.stderr
    assert f"signature              = {signature};" in text
    for memory in ("flash", "lfuse", "hfuse", "efuse"):
        assert f'memory "{memory}"' in text


def avrdude_has_dryrun():
    listing = subprocess.run([avrdude, "-c", "?"], capture_output=True, text=True, timeout=30)
    return re.search(r"^\s*dryrun\s+=", listing.stdout + listing.stderr, re.M) is not None


@pytest.mark.skipif(avrdude is None, reason="avrdude not installed (scripts/setup)")
@pytest.mark.parametrize("mcu", ["atmega88", "atmega328p"])
def test_real_avrdude_against_its_dryrun_programmer(mcu):
    """avrdude 7.2 and later emulate a part with `-c dryrun`: the real command line, run. Debian
    12's avrdude 7.1 has no such programmer (skipped there)."""
    if not avrdude_has_dryrun():
        pytest.skip("this avrdude has no dryrun programmer (added after 7.1)")
    run = flash_isp("--programmer", "dryrun", "--mcu", mcu)
    assert run.returncode == 0, run.stderr
    for memory in ("flash", "lfuse", "hfuse", "efuse"):
        assert re.search(rf"{memory}\b.*verified", run.stderr), (memory, run.stderr[-2000:])


@pytest.fixture
def fake_programmer(request):
    from fake_stk500 import FakeStk500
    programmer = FakeStk500(request.param)
    yield programmer
    programmer.close()


@pytest.mark.skipif(avrdude is None, reason="avrdude not installed (scripts/setup)")
@pytest.mark.parametrize("fake_programmer", ["atmega88", "atmega328p"], indirect=True)
def test_real_avrdude_against_a_simulated_programmer(fake_programmer):
    """The real avrdude, run by flash-isp, against an STK500v1 programmer simulated on a
    pseudo-terminal (test/board/fake_stk500.py) with its target part: it reads the HEX, erases,
    writes and verifies the flash, and writes the fuses; then a second flash keeps the EEPROM
    (EESAVE, now programmed) through the chip erase."""
    from intelhex import IntelHex
    mcu = "atmega88" if fake_programmer.signature[1] == 0x93 else "atmega328p"
    run = flash_isp("--programmer", "stk500v1", "--port", fake_programmer.port, "--mcu", mcu)
    assert run.returncode == 0, run.stderr[-3000:]
    assert "failed" not in run.stderr and "error" not in run.stderr, run.stderr[-3000:]
    boot = mcu in ax12_fuses.BOOTLOADER_MCUS  # the merged HEX: application, record, bootloader
    image = IntelHex(os.path.join(BUILD, "firmware", f"ax12-ax12-{mcu}{'-merged' if boot else ''}.hex"))
    written = bytes(fake_programmer.flash)
    for start, stop in image.segments():
        assert written[start:stop] == image.tobinstr(start=start, end=stop - 1)
    assert sum(1 for b in written if b != 0xFF) == sum(1 for a in image.addresses() if image[a] != 0xFF)
    assert re.search(r"\d+ bytes of flash verified", run.stderr)
    assert fake_programmer.erased == 1
    assert fake_programmer.fuses == ax12_fuses.fuses(mcu, bootloader=boot)

    fake_programmer.eeprom[:27] = bytes(range(27))  # settings saved by the firmware
    run = flash_isp("--programmer", "stk500v1", "--port", fake_programmer.port, "--mcu", mcu, "--profile", "ax12a")
    assert run.returncode == 0, run.stderr[-3000:]
    assert fake_programmer.erased == 2
    assert bytes(fake_programmer.eeprom[:27]) == bytes(range(27)), "EESAVE: the settings survive a reflash"
