# SPDX-License-Identifier: GPL-3.0-or-later
"""The application image as the bootloader takes it (docs/bootloader.md "Flash layout"): an
Intel HEX file read into the bytes from address 0, checked against the target part, cut into
flash pages, and its application record.

- load(path) reads a HEX file (intelhex) or raises ImageError with a message naming the file;
- image.check_target(mcu, app_area_bytes, page_bytes) refuses an image built for another
  part or too large for the application area less its record page;
- image.check_flashable() refuses, before any servo is asked anything, an image no servo's
  bootloader takes: not an application, for a part without a bootloader, or too large for its
  part's application area (a merged HEX with the bootloader in it, say);
- area_text(app_area_bytes, page_bytes) names the application area and its parts, the one
  wording of every message about it;
- image.pages(page_bytes) are the (address, bytes) to write, the last one padded with 0xFF;
- record_page(length, crc, page_bytes) is the record page, as firmware/boot/boot_image.c
  builds it;
- merged_hex(image, boot_hex, mcu) is what a new board's flash holds: application, record
  page and bootloader (the build writes it: scripts/ax12_merge_hex.py).

Part facts (signature, page size, the limits) come from python/ax12_fuses.py's MCUS.
"""

from dataclasses import dataclass

from intelhex import IntelHex, IntelHexError

import ax12_fuses

RECORD_MAGIC = b"AXAP"
CRC_INITIAL = 0xFFFF
ERASED = 0xFF
VECTORS = 26  # interrupt vectors of both parts (reset included)


class ImageError(Exception):
    """A file that cannot be flashed, or not to this part; the message says why."""


def crc16(data, crc=CRC_INITIAL):
    """CRC-16/CCITT-FALSE (polynomial 0x1021, no reflection, no final XOR) of data, continued
    from crc: the firmware's dxl_crc16_update. crc16(b"123456789") == 0x29B1."""
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else (crc << 1)
            crc &= 0xFFFF
    return crc


def record_page(length, crc, page_bytes):
    """The record page of an image of length bytes with this CRC: "AXAP", length and CRC
    (16 bits each, little-endian), the rest 0xFF."""
    record = RECORD_MAGIC + length.to_bytes(2, "little") + crc.to_bytes(2, "little")
    return record + bytes([ERASED]) * (page_bytes - len(record))


def part_application_area(mcu):
    """(application area bytes, page bytes) of a part with a bootloader, from its facts
    (ax12_fuses.MCUS): the flash below the boot section, the record page included."""
    part = ax12_fuses.MCUS[mcu]
    return part.flash_bytes - part.boot_section_bytes, part.page_bytes


def area_text(app_area_bytes, page_bytes):
    """The application area as every message names it: the image's part and the record's."""
    record_at = app_area_bytes - page_bytes
    return (f"application area 0x0000-0x{app_area_bytes - 1:04X}: the image 0x0000-0x{record_at - 1:04X} "
            f"({record_at} B at most), its record 0x{record_at:04X}-0x{app_area_bytes - 1:04X}")


def _words(data, count):
    return [data[2 * i] | (data[2 * i + 1] << 8) for i in range(count)]


def _is_rjmp(word):
    return word & 0xF000 == 0xC000


def vector_table_mcu(data):
    """The part whose vector table data starts with, or None.

    ATmega328P: 26 vectors of two words, each a JMP (0x940C / 0x940D, then the address) or,
    where the linker relaxed it, an RJMP (0xCxxx) and a NOP (0x0000). ATmega88: 26 vectors of
    one word, each an RJMP. Neither can be read as the other (the 88's second word is an RJMP,
    never a NOP or the first of a JMP)."""
    if len(data) >= 4 * VECTORS:
        words = _words(data, 2 * VECTORS)
        if all(words[2 * i] in (0x940C, 0x940D) or (_is_rjmp(words[2 * i]) and words[2 * i + 1] == 0)
               for i in range(VECTORS)):
            return "atmega328p"
    if len(data) >= 2 * VECTORS and all(_is_rjmp(word) for word in _words(data, VECTORS)):
        return "atmega88"
    return None


def mcu_of_signature(signature):
    """The name (ax12_fuses.MCUS) of the part with these three signature bytes, or None."""
    for mcu in ax12_fuses.MCUS.values():
        if mcu.signature == bytes(signature):
            return mcu.name
    return None


@dataclass(frozen=True)
class AppImage:
    path: str
    data: bytes  # from address 0 to the last byte the file gives; gaps 0xFF

    @property
    def crc(self):
        return crc16(self.data)

    @property
    def built_for(self):
        """The part its vector table is for (vector_table_mcu), or None."""
        return vector_table_mcu(self.data)

    def check_target(self, mcu, app_area_bytes, page_bytes):
        """Raises ImageError unless the image is for mcu (its vector table) and fits the
        application area (app_area_bytes, the record page included) less the record page."""
        built_for = self.built_for
        if built_for is None:
            raise ImageError(self._not_an_application())
        if built_for != mcu:
            raise ImageError(f"{self.path} is built for the {built_for}, the servo is an {mcu}")
        limit = app_area_bytes - page_bytes
        if len(self.data) > limit:
            merged = (" (it reaches into the boot section: a HEX with the bootloader in it is for "
                      "`scripts/ax12 flash-isp`; `flash` takes the application alone, "
                      "ax12-<profile>-<mcu>.hex)" if len(self.data) > app_area_bytes else "")
            raise ImageError(f"{self.path} is {len(self.data)} B, more than the {mcu}'s "
                             f"{area_text(app_area_bytes, page_bytes)}{merged}")

    def check_flashable(self):
        """Raises ImageError unless some servo's bootloader could take the image: an
        application's vector table, for a part with a bootloader (ax12_fuses.BOOTLOADER_MCUS),
        fitting that part's application area. Checked before a servo is asked into its
        bootloader, so a refused file never leaves one there."""
        built_for = self.built_for
        if built_for is None:
            raise ImageError(self._not_an_application())
        if built_for not in ax12_fuses.BOOTLOADER_MCUS:
            raise ImageError(f"{self.path} is built for the {built_for}, which has no bootloader: "
                             f"no servo takes it over the bus (write it over ISP: `scripts/ax12 flash-isp`)")
        self.check_target(built_for, *part_application_area(built_for))

    def _not_an_application(self):
        return (f"{self.path}: its first bytes are not an AVR vector table "
                f"(26 JMP or RJMP instructions): not an Open AX-12 application")

    def pages(self, page_bytes):
        """[(address, page_bytes bytes)] covering the image, the last padded with 0xFF."""
        padded = self.data + bytes([ERASED]) * (-len(self.data) % page_bytes)
        return [(address, padded[address:address + page_bytes]) for address in range(0, len(padded), page_bytes)]

    def record_page(self, page_bytes):
        return record_page(len(self.data), self.crc, page_bytes)


def load(path):
    """The AppImage of an Intel HEX file. Raises ImageError for a missing or unreadable file,
    one that is not Intel HEX (a bad record checksum included, or a truncated file without its
    end-of-file record), one with no data, or one that does not start at address 0."""
    try:
        with open(path, "r") as f:
            text = f.read()
    except FileNotFoundError:
        raise ImageError(f"no such file: {path}")
    except (OSError, UnicodeDecodeError) as error:
        raise ImageError(f"{path} cannot be read as an Intel HEX file ({error})")
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    if not lines or lines[-1].upper() != ":00000001FF":
        raise ImageError(f"{path} is not a whole Intel HEX file (it does not end with the "
                         f"end-of-file record :00000001FF: cut short?)")
    hex_file = IntelHex()
    try:
        hex_file.loadhex(path)
    except (IntelHexError, ValueError) as error:
        raise ImageError(f"{path} is not an Intel HEX file ({error})")
    if len(hex_file) == 0:
        raise ImageError(f"{path} holds no data")
    if hex_file.minaddr() != 0:
        raise ImageError(f"{path} starts at 0x{hex_file.minaddr():04X}: an application image starts at 0x0000")
    hex_file.padding = ERASED
    return AppImage(path, hex_file.tobinstr(start=0, end=hex_file.maxaddr()))


def merged_hex(image, boot_hex_path, mcu):
    """An IntelHex of the whole flash a new board gets: the image at 0, its record page at the
    top of the application area and the bootloader's HEX in the boot section. Raises
    ImageError when the image does not fit or is for another part, or when the bootloader's
    HEX holds bytes outside the boot section."""
    part = ax12_fuses.MCUS[mcu]
    boot_start, _ = part_application_area(mcu)
    image.check_target(mcu, boot_start, part.page_bytes)
    try:
        boot = IntelHex(boot_hex_path)
    except (IntelHexError, ValueError, OSError) as error:
        raise ImageError(f"{boot_hex_path} is not an Intel HEX file ({error})")
    if len(boot) == 0 or boot.minaddr() < boot_start or boot.maxaddr() >= part.flash_bytes:
        raise ImageError(f"{boot_hex_path}: the bootloader's bytes must lie in the boot section "
                         f"0x{boot_start:04X}-0x{part.flash_bytes - 1:04X}")
    merged = IntelHex()
    merged.frombytes(image.data, offset=0)
    merged.frombytes(image.record_page(part.page_bytes), offset=boot_start - part.page_bytes)
    merged.merge(boot, overlap="error")
    return merged
