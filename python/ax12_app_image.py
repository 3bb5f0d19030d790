# SPDX-License-Identifier: GPL-3.0-or-later
"""The application image as the bootloader takes it (docs/bootloader.md "Flash layout"): an
Intel HEX file read into the bytes from address 0, checked against the target part, cut into
flash pages, and its application record.

- load(path) reads a HEX file (intelhex) or raises ImageError with a message naming the file;
- load(path) reads a HEX file (intelhex) or raises ImageError with a message naming the file;
- image.check_target(mcu) refuses an image built for another part or too large for the
  application area less the record;
- image.check_flashable() refuses, before any servo is asked anything, an image no servo's
  bootloader takes: not an application, or too large for its part's application area (a
  merged HEX with the bootloader in it, say);
- area_text(mcu) names the part's application area and its parts, the one wording of every
  message about it;
- image.update_pages(mcu) are the (address, bytes) pages of an update in the order they are
  written: the record's page first with the record erased, the image's other pages, the
  record's page last with the record;
- record(length, check) is the record, as firmware/boot/boot_image.c builds it;
- merged_hex(image, boot_hex, mcu) is what a new board's flash holds: application, record and
  bootloader (the build writes it: scripts/ax12_merge_hex.py).

Part facts (signature, page size, the boot section) come from python/ax12_fuses.py's MCUS.
"""

from dataclasses import dataclass

from intelhex import IntelHex, IntelHexError

import ax12_fuses

ERASED = 0xFF
VECTORS = 26  # interrupt vectors of both parts (reset included)


class ImageError(Exception):
    """A file that cannot be flashed, or not to this part; the message says why."""


def check_value(data, check=0):
    """The bootloader's check value of data, continued from check: Fletcher-16 modulo 256,
    sum1 in the low byte, sum2 in the high byte (firmware/boot/boot_image.c)."""
    sum1, sum2 = check & 0xFF, check >> 8
    for byte in data:
        sum1 = (sum1 + byte) & 0xFF
        sum2 = (sum2 + sum1) & 0xFF
    return sum1 | (sum2 << 8)


def record(length, check):
    """The application record of an image of length bytes with this check value: the address
    of its last byte and the check value, 16 bits each, little-endian."""
    return (length - 1).to_bytes(2, "little") + check.to_bytes(2, "little")


def area_text(mcu):
    """The part's application area (the flash below the boot section, ax12_fuses.MCUS) as every
    message names it: the image's part and the record's."""
    part = ax12_fuses.MCUS[mcu]
    return (f"application area 0x0000-0x{part.boot_start - 1:04X}: the image 0x0000-0x{part.record_at - 1:04X} "
            f"({part.record_at} B at most), its record 0x{part.record_at:04X}-0x{part.boot_start - 1:04X}")


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
    def check(self):
        return check_value(self.data)

    @property
    def built_for(self):
        """The part its vector table is for (vector_table_mcu), or None."""
        return vector_table_mcu(self.data)

    def check_target(self, mcu):
        """Raises ImageError unless the image is for mcu (its vector table) and ends below the
        application record (the application area less the record)."""
        built_for = self.built_for
        if built_for is None:
            raise ImageError(self._not_an_application())
        if built_for != mcu:
            raise ImageError(f"{self.path} is built for the {built_for}, the servo is an {mcu}")
        limit = ax12_fuses.MCUS[mcu].record_at
        if len(self.data) > limit:
            merged = (" (it reaches into the boot section: a HEX with the bootloader in it is for "
                      "`scripts/ax12 flash-isp`; `flash` takes the application alone, "
                      "ax12-<profile>-<mcu>.hex)" if len(self.data) > ax12_fuses.MCUS[mcu].boot_start else "")
            raise ImageError(f"{self.path} is {len(self.data)} B, more than the {mcu}'s "
                             f"{area_text(mcu)}{merged}")

    def check_flashable(self):
        """Raises ImageError unless its own part's bootloader could take the image: an
        application's vector table, fitting that part's application area less the record.
        Checked before a servo is asked into its bootloader, so a refused file never leaves one
        there."""
        built_for = self.built_for
        if built_for is None:
            raise ImageError(self._not_an_application())
        self.check_target(built_for)

    def _not_an_application(self):
        return (f"{self.path}: its first bytes are not an AVR vector table "
                f"(26 JMP or RJMP instructions): not an Open AX-12 application")

    def flash_bytes(self, mcu, with_record=True):
        """The application area as the update leaves it where it writes: the image, 0xFF up
        to the record, the record (or 0xFF for it)."""
        part = ax12_fuses.MCUS[mcu]
        tail = record(len(self.data), self.check) if with_record else bytes([ERASED]) * ax12_fuses.RECORD_BYTES
        return self.data + bytes([ERASED]) * (part.record_at - len(self.data)) + tail

    def update_pages(self, mcu):
        """[(address, page bytes)] of an update, in order: the record's page with the record
        erased (from there on the application is not valid), every other page that holds
        image bytes, the record's page with the record (written last: from there on it is)."""
        part = ax12_fuses.MCUS[mcu]
        page = part.page_bytes
        record_page = part.record_at - part.record_at % page
        without, whole = self.flash_bytes(mcu, with_record=False), self.flash_bytes(mcu)
        middle = [(address, whole[address:address + page]) for address in range(0, len(self.data), page)
                  if address != record_page]
        return ([(record_page, without[record_page:record_page + page])] + middle
                + [(record_page, whole[record_page:record_page + page])])


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
    """An IntelHex of the whole flash a new board gets: the image at 0, its record below the
    boot section and the bootloader's HEX in the boot section. Raises ImageError when the
    image does not fit or is for another part, or when the bootloader's HEX holds bytes
    outside the boot section."""
    part = ax12_fuses.MCUS[mcu]
    image.check_target(mcu)
    try:
        boot = IntelHex(boot_hex_path)
    except (IntelHexError, ValueError, OSError) as error:
        raise ImageError(f"{boot_hex_path} is not an Intel HEX file ({error})")
    if len(boot) == 0 or boot.minaddr() < part.boot_start or boot.maxaddr() >= part.flash_bytes:
        raise ImageError(f"{boot_hex_path}: the bootloader's bytes must lie in the boot section "
                         f"0x{part.boot_start:04X}-0x{part.flash_bytes - 1:04X}")
    merged = IntelHex()
    merged.frombytes(image.data, offset=0)
    merged.frombytes(record(len(image.data), image.check), offset=part.record_at)
    merged.merge(boot, overlap="error")
    return merged
