# SPDX-License-Identifier: MIT
"""The fuse bytes of an Open AX-12 board, per MCU: the one place they are written.

`scripts/ax12 flash-isp` writes them with avrdude; docs/hardware.md ("Fuses") gives the same
values and the reason for each bit, and test/board checks that the two agree. A fuse bit is
*programmed* when it reads 0.

Each byte is built from named fields, so a value here can be read against the datasheet's
fuse tables (ATmega48/88/168 and ATmega328P, "Memory Programming").
"""

from dataclasses import dataclass


# The boot section (docs/bootloader.md "Flash layout"): its top 512 B on both parts; the
# application record takes the last 4 B below it.
BOOT_SECTION_BYTES = 512
RECORD_BYTES = 4

# The parts whose builds carry the bootloader (firmware/boot; cmake/firmware.cmake's
# AX12_FIRMWARE_BOOTABLE_MCUS): their board gets the merged HEX (application, record,
# bootloader) and BOOTRST programmed, and their application ends below the record.
BOOTLOADER_MCUS = {"atmega88", "atmega328p"}


@dataclass(frozen=True)
class Mcu:
    name: str             # as the build names it: ax12-<profile>-<name>.elf
    part: str             # avrdude's -p
    signature: bytes      # the part's three signature bytes (the bootloader's INFO gives them)
    flash_bytes: int
    page_bytes: int       # flash page size (SPM writes a page at a time)

    boot_section_bytes = BOOT_SECTION_BYTES

    @property
    def boot_start(self):
        """The boot section's first byte: the end of the application area."""
        return self.flash_bytes - BOOT_SECTION_BYTES

    @property
    def record_at(self):
        """The application record's first byte (the last RECORD_BYTES of the application area)."""
        return self.boot_start - RECORD_BYTES

    @property
    def app_limit_bytes(self):
        """What the application image itself may occupy: up to the record beside the
        bootloader, the whole flash on a part without it."""
        return self.record_at if self.name in BOOTLOADER_MCUS else self.flash_bytes


MCUS = {
    "atmega88": Mcu("atmega88", "m88", bytes([0x1E, 0x93, 0x0A]), 8192, 64),
    "atmega328p": Mcu("atmega328p", "m328p", bytes([0x1E, 0x95, 0x0F]), 32768, 128),
}

# Low byte, the same on both parts: CKDIV8 1 (not divided), CKOUT 1 (no clock on PB0),
# SUT1:0 01 and CKSEL3:0 0111: full-swing crystal oscillator, 16K CK start-up + 14 CK,
# the start-up time meant for use with brown-out detection.
_LOW = {"CKDIV8": 1, "CKOUT": 1, "SUT": 0b01, "CKSEL": 0b0111}
_BODLEVEL_4V3 = 0b100


def _byte(fields, layout):
    """fields: name -> value; layout: (name, width) from bit 7 down; unused bits read 1."""
    value, bit = 0, 8
    for name, width in layout:
        bit -= width
        value |= (fields.get(name, (1 << width) - 1) & ((1 << width) - 1)) << bit
    assert bit == 0
    return value


_LOW_LAYOUT = [("CKDIV8", 1), ("CKOUT", 1), ("SUT", 2), ("CKSEL", 4)]
_HIGH_COMMON = {"RSTDISBL": 1, "DWEN": 1, "SPIEN": 0, "WDTON": 1, "EESAVE": 0}


def fuse_fields(mcu, bootloader=False):
    """The named fields of each fuse byte: {"lfuse": {...}, "hfuse": {...}, "efuse": {...}}.

    bootloader: whether a bootloader is written with the application (the ATmega328P's merged
    HEX). BOOTRST (reset into the boot section) is programmed only then: with an empty (erased)
    boot section the reset would run from 0xFFFF words the datasheet does not define as
    instructions, and on the ATmega88 the application itself runs through the boot section's
    addresses.
    """
    bootrst = 0 if bootloader else 1
    if mcu == "atmega88":
        return {
            "lfuse": dict(_LOW),
            "hfuse": dict(_HIGH_COMMON, BODLEVEL=_BODLEVEL_4V3),
            # BOOTSZ 10: 256 words = 512 B boot section, 0x1E00-0x1FFF.
            "efuse": {"BOOTSZ": 0b10, "BOOTRST": bootrst},
        }
    if mcu == "atmega328p":
        return {
            "lfuse": dict(_LOW),
            # BOOTSZ 11: 256 words = 512 B boot section, 0x7E00-0x7FFF.
            "hfuse": dict(_HIGH_COMMON, BOOTSZ=0b11, BOOTRST=bootrst),
            "efuse": {"BODLEVEL": _BODLEVEL_4V3},
        }
    raise KeyError(mcu)


_LAYOUTS = {
    "atmega88": {
        "lfuse": _LOW_LAYOUT,
        "hfuse": [("RSTDISBL", 1), ("DWEN", 1), ("SPIEN", 1), ("WDTON", 1), ("EESAVE", 1), ("BODLEVEL", 3)],
        "efuse": [("unused", 5), ("BOOTSZ", 2), ("BOOTRST", 1)],
    },
    "atmega328p": {
        "lfuse": _LOW_LAYOUT,
        "hfuse": [("RSTDISBL", 1), ("DWEN", 1), ("SPIEN", 1), ("WDTON", 1), ("EESAVE", 1), ("BOOTSZ", 2), ("BOOTRST", 1)],
        "efuse": [("unused", 5), ("BODLEVEL", 3)],
    },
}


def fuses(mcu, bootloader=False):
    """The fuse bytes to write: {"lfuse": int, "hfuse": int, "efuse": int}."""
    fields = fuse_fields(mcu, bootloader)
    return {name: _byte(fields[name], _LAYOUTS[mcu][name]) for name in ("lfuse", "hfuse", "efuse")}


if __name__ == "__main__":
    for name in MCUS:
        for boot in (False, True):
            values = fuses(name, boot)
            print(name, "with bootloader" if boot else "application only",
                  " ".join(f"{k}=0x{v:02X}" for k, v in values.items()))
