# SPDX-License-Identifier: GPL-3.0-or-later
"""python/ax12_app_image.py, the application image the bootloader takes (docs/bootloader.md):
its check value, its record, the pages of an update in their order, which part a vector table
is for, and the files it refuses (not Intel HEX, a bad record checksum, cut short, not from
address 0, too large, for the other part)."""

import os

import pytest
from intelhex import IntelHex

import ax12_app_image as image_module
from ax12_app_image import ImageError

FIRMWARE_DIR = os.environ.get("AX12_FIRMWARE_DIR") or os.path.join(
    os.path.dirname(__file__), "..", "..", "build", "firmware")


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


def test_check_value_is_fletcher_16_modulo_256():
    # As firmware/boot/boot_image.c (test/boot/test_boot_image.c: the same values).
    assert image_module.check_value(b"") == 0x0000
    assert image_module.check_value(b"\x01\x02") == 0x0403
    assert image_module.check_value(b"\xff\xff") == 0xFDFE
    assert image_module.check_value(b"56789", image_module.check_value(b"1234")) == \
        image_module.check_value(b"123456789"), "continues from a check value"


def test_record_bytes():
    assert image_module.record(0x1234, 0xBEEF) == bytes([0x33, 0x12, 0xEF, 0xBE])


def update_addresses(pages):
    return [address for address, _ in pages]


def test_update_pages_erase_the_record_first_and_write_it_last(tmp_path):
    data = jmp_vectors() + bytes(range(200))  # 304 B: two whole pages and 48 bytes
    image = image_module.load(write_hex(tmp_path / "app.hex", data))
    pages = image.update_pages("atmega328p")
    assert update_addresses(pages) == [0x7D80, 0, 128, 256, 0x7D80]
    assert all(len(page) == 128 for _, page in pages)
    assert b"".join(page for _, page in pages[1:4]) == data + b"\xff" * 80
    assert pages[0][1] == b"\xff" * 128, "the record erased"
    assert pages[-1][1] == b"\xff" * 124 + image_module.record(304, image_module.check_value(data))
    flash = image.flash_bytes("atmega328p")
    assert len(flash) == 0x7E00 and flash[:304] == data and flash[0x7DFC:] == pages[-1][1][-4:]


def test_an_image_that_reaches_the_record_page_is_written_there_first_without_the_record(tmp_path):
    data = rjmp_vectors() + bytes(i & 0xFF for i in range(0x1DFC - 52))  # up to the record: 7676 B
    image = image_module.load(write_hex(tmp_path / "app.hex", data))
    image.check_target("atmega88")
    pages = image.update_pages("atmega88")
    assert update_addresses(pages) == [0x1DC0] + list(range(0, 0x1DC0, 64)) + [0x1DC0]
    assert pages[0][1] == data[0x1DC0:] + b"\xff" * 4
    assert pages[-1][1] == data[0x1DC0:] + image_module.record(len(data), image_module.check_value(data))


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
        image.check_target("atmega328p")


def test_image_that_is_no_application_refused(tmp_path):
    image = image_module.load(write_hex(tmp_path / "data.hex", bytes(range(256))))
    with pytest.raises(ImageError, match="not an AVR vector table"):
        image.check_target("atmega328p")


def test_image_up_to_the_record_accepted_one_byte_more_refused(tmp_path):
    fits = jmp_vectors() + b"\x00" * (0x7DFC - 104)
    image_module.load(write_hex(tmp_path / "fits.hex", fits)).check_target("atmega328p")
    too_large = image_module.load(write_hex(tmp_path / "big.hex", fits + b"\x00"))
    with pytest.raises(ImageError, match=r"32253 B, more than the atmega328p's application area 0x0000-0x7DFF: "
                                         r"the image 0x0000-0x7DFB \(32252 B at most\), its record 0x7DFC-0x7DFF"):
        too_large.check_target("atmega328p")


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
