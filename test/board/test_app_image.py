# SPDX-License-Identifier: GPL-3.0-or-later
"""python/ax12_app_image.py, the application image the bootloader takes (docs/bootloader.md):
its CRC, its record page, its pages, which part a vector table is for, and the files it
refuses (not Intel HEX, a bad record checksum, cut short, not from address 0, too large, for
the other part)."""

import os

import pytest
from intelhex import IntelHex

import ax12_app_image as image_module
from ax12_app_image import ImageError

FIRMWARE_DIR = os.environ.get("AX12_FIRMWARE_DIR") or os.path.join(
    os.path.dirname(__file__), "..", "..", "build", "firmware")
AREA_328P, PAGE_328P = 0x7800, 128


def jmp_vectors(count=26):
    """An ATmega328P vector table: JMP 0x0068 (word address 0x34) in every vector."""
    return bytes([0x0C, 0x94, 0x34, 0x00]) * count


def relaxed_vectors():
    """The same with the linker's relaxation where it applies: RJMP + NOP in some vectors."""
    table = bytearray(jmp_vectors())
    for vector in (0, 1, 5, 25):
        table[4 * vector:4 * vector + 4] = bytes([0x33, 0xC0, 0x00, 0x00])
    return bytes(table)


def rjmp_vectors():
    """An ATmega88 vector table: 26 RJMPs."""
    return bytes([0x19, 0xC0]) * 26


def write_hex(path, data, offset=0):
    hex_file = IntelHex()
    hex_file.frombytes(data, offset=offset)
    hex_file.write_hex_file(str(path))
    return str(path)


def test_crc_known_value():
    assert image_module.crc16(b"123456789") == 0x29B1
    assert image_module.crc16(b"") == 0xFFFF
    assert image_module.crc16(b"56789", image_module.crc16(b"1234")) == 0x29B1, "continues from a CRC"


def test_record_page_bytes():
    page = image_module.record_page(0x1FC4, 0xBEEF, 128)
    assert page[:8] == bytes([0x41, 0x58, 0x41, 0x50, 0xC4, 0x1F, 0xEF, 0xBE])
    assert len(page) == 128 and set(page[8:]) == {0xFF}


def test_image_record_page_has_its_length_and_crc(tmp_path):
    data = jmp_vectors() + bytes(range(7))
    image = image_module.load(write_hex(tmp_path / "app.hex", data))
    assert image.data == data
    assert image.record_page(128) == image_module.record_page(len(data), image_module.crc16(data), 128)


def test_pages_are_padded_with_ff(tmp_path):
    data = jmp_vectors() + bytes(range(200))  # 304 B: two whole pages and 48 bytes
    pages = image_module.load(write_hex(tmp_path / "app.hex", data)).pages(128)
    assert [address for address, _ in pages] == [0, 128, 256]
    assert all(len(page) == 128 for _, page in pages)
    assert b"".join(page for _, page in pages) == data + b"\xff" * 80


def test_gaps_read_as_erased_flash(tmp_path):
    hex_file = IntelHex()
    hex_file.frombytes(jmp_vectors(), offset=0)
    hex_file.frombytes(b"\x01\x02", offset=200)
    path = tmp_path / "gaps.hex"
    hex_file.write_hex_file(str(path))
    data = image_module.load(str(path)).data
    assert len(data) == 202 and data[104:200] == b"\xff" * 96 and data[200:] == b"\x01\x02"


@pytest.mark.parametrize("table,mcu", [(jmp_vectors(), "atmega328p"), (relaxed_vectors(), "atmega328p"),
                                       (rjmp_vectors(), "atmega88"), (b"\x00" * 104, None),
                                       (jmp_vectors(25) + b"\xff" * 4, None)])
def test_vector_table_names_the_part(table, mcu):
    assert image_module.vector_table_mcu(table + b"\x00" * 16) == mcu


@pytest.mark.parametrize("profile", ["ax12", "ax12a"])
@pytest.mark.parametrize("mcu", ["atmega88", "atmega328p"])
def test_the_builds_are_recognised(profile, mcu):
    path = os.path.join(FIRMWARE_DIR, f"ax12-{profile}-{mcu}.hex")
    assert image_module.load(path).built_for == mcu


def test_signatures_name_the_parts():
    assert image_module.mcu_of_signature(b"\x1e\x95\x0f") == "atmega328p"
    assert image_module.mcu_of_signature(b"\x1e\x93\x0a") == "atmega88"
    assert image_module.mcu_of_signature(b"\x1e\x95\x14") is None


def test_image_for_the_other_part_refused(tmp_path):
    image = image_module.load(os.path.join(FIRMWARE_DIR, "ax12-ax12-atmega88.hex"))
    with pytest.raises(ImageError, match="built for the atmega88, the servo is an atmega328p"):
        image.check_target("atmega328p", AREA_328P, PAGE_328P)


def test_image_that_is_no_application_refused(tmp_path):
    image = image_module.load(write_hex(tmp_path / "data.hex", bytes(range(256))))
    with pytest.raises(ImageError, match="not an AVR vector table"):
        image.check_target("atmega328p", AREA_328P, PAGE_328P)


def test_image_up_to_the_record_page_accepted_one_byte_more_refused(tmp_path):
    fits = jmp_vectors() + b"\x00" * (0x7780 - 104)
    image_module.load(write_hex(tmp_path / "fits.hex", fits)).check_target("atmega328p", AREA_328P, PAGE_328P)
    too_large = image_module.load(write_hex(tmp_path / "big.hex", fits + b"\x00"))
    with pytest.raises(ImageError, match=r"30593 B, more than the atmega328p's application area 0x0000-0x77FF: "
                                         r"the image 0x0000-0x777F \(30592 B at most\)"):
        too_large.check_target("atmega328p", AREA_328P, PAGE_328P)


def test_not_a_hex_file_refused(tmp_path):
    text = tmp_path / "notes.hex"
    text.write_text("these are not records\n")
    with pytest.raises(ImageError, match="not"):
        image_module.load(str(text))
    elf = os.path.join(FIRMWARE_DIR, "ax12-ax12-atmega328p.elf")
    with pytest.raises(ImageError, match="Intel HEX"):
        image_module.load(elf)
    with pytest.raises(ImageError, match="no such file"):
        image_module.load(str(tmp_path / "none.hex"))


def flipped_data_byte(lines):
    """lines with the first data record's first data byte changed, its checksum left: the
    record's checksum is then wrong."""
    line = lines[0]
    byte = int(line[9:11], 16) ^ 0x01
    return [line[:9] + f"{byte:02X}" + line[11:]] + lines[1:]


def test_flipped_data_byte_refused(tmp_path):
    lines = open(os.path.join(FIRMWARE_DIR, "ax12-ax12a-atmega328p.hex")).read().splitlines()
    bad = tmp_path / "flipped.hex"
    bad.write_text("\n".join(flipped_data_byte(lines)) + "\n")
    with pytest.raises(ImageError, match="not an Intel HEX file"):
        image_module.load(str(bad))


@pytest.mark.parametrize("cut", ["between records", "inside a record"])
def test_truncated_file_refused(tmp_path, cut):
    text = open(os.path.join(FIRMWARE_DIR, "ax12-ax12a-atmega328p.hex")).read()
    lines = text.splitlines()
    half = "\n".join(lines[:len(lines) // 2]) + "\n"
    if cut == "inside a record":
        half = half[:-12]
    short = tmp_path / "short.hex"
    short.write_text(half)
    with pytest.raises(ImageError):
        image_module.load(str(short))


def test_image_not_from_zero_refused(tmp_path):
    path = write_hex(tmp_path / "high.hex", jmp_vectors(), offset=0x100)
    with pytest.raises(ImageError, match="starts at 0x0100"):
        image_module.load(path)


def test_empty_file_refused(tmp_path):
    empty = tmp_path / "empty.hex"
    empty.write_text(":00000001FF\n")
    with pytest.raises(ImageError, match="no data"):
        image_module.load(str(empty))
