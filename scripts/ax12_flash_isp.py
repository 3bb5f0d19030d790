#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""scripts/ax12 flash-isp: write the firmware and the fuses to a board over its ISP header.

Runs avrdude with the part (-p m88 / m328p), the programmer, the flash image in Intel HEX and
the fuse bytes of python/ax12_fuses.py (docs/hardware.md "Fuses"). The image: on a part with a
bootloader (both) the merged HEX, build/firmware/ax12-<profile>-<mcu>-merged.hex
(application, record page, bootloader), with BOOTRST programmed, so the board can then be
updated over the bus (`scripts/ax12 flash`); with --app-only the application's HEX alone
(ax12-<profile>-<mcu>.hex) with BOOTRST unprogrammed. --hex FILE
writes another image: one with bytes in the boot section is taken as a whole flash with its
bootloader, any other as an application alone. The flash is written first, then the fuses:
a new part still runs from its internal 1 MHz oscillator while the flash is written, and a
board whose crystal does not start is then still running the new firmware's bytes in flash,
not locked out half-way. `--dry-run` prints the avrdude command line and runs nothing.

Exit status: avrdude's; 2 for bad input (nothing run).
"""

import argparse
import os
import shlex
import shutil
import subprocess
import sys

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "python"))

import ax12_fuses  # noqa: E402


class BadInput(Exception):
    pass


def check_hex(path, mcu, with_bootloader):
    """Raises BadInput unless path is a readable Intel HEX file whose image fits: mcu's
    application area (python/ax12_fuses.py: app_limit_bytes) for an application alone, the
    whole flash with bytes in the boot section for an image with its bootloader. Returns
    whether the image holds a bootloader (bytes in the boot section)."""
    if not os.path.isfile(path):
        raise BadInput(f"no such HEX file: {path} (`scripts/ax12 build` writes build/firmware/"
                       f"ax12-<profile>-<mcu>.hex and, for a part with a bootloader, -merged.hex; "
                       f"or give --hex FILE)")
    try:
        from intelhex import IntelHex, IntelHexError
    except ImportError:
        raise BadInput("the Python package intelhex is missing: run scripts/setup")
    try:
        image = IntelHex(path)
    except (IntelHexError, UnicodeDecodeError, ValueError) as error:
        raise BadInput(f"{path} is not an Intel HEX file ({error})")
    if len(image) == 0:
        raise BadInput(f"{path} is not an Intel HEX file (no data records)")
    part = ax12_fuses.MCUS[mcu]
    boot_start = part.flash_bytes - part.boot_section_bytes
    if with_bootloader is None:  # --hex: what the file holds decides
        with_bootloader = mcu in ax12_fuses.BOOTLOADER_MCUS and image.maxaddr() >= boot_start
    if with_bootloader:
        if image.minaddr() != 0 or image.maxaddr() >= part.flash_bytes or image.maxaddr() < boot_start:
            raise BadInput(f"{path} spans 0x{image.minaddr():04X}-0x{image.maxaddr():04X}: not a whole "
                           f"{mcu} flash with its bootloader at 0x{boot_start:04X}")
        return True
    limit = part.app_limit_bytes
    if image.minaddr() < 0 or image.maxaddr() >= limit:
        raise BadInput(f"{path} spans 0x{image.minaddr():04X}-0x{image.maxaddr():04X}: "
                       f"outside the {mcu}'s application area 0x0000-0x{limit - 1:04X}")
    return False


def known_programmers(avrdude):
    """The programmer ids avrdude's configuration knows, or None when it cannot list them."""
    try:
        listing = subprocess.run([avrdude, "-c", "?"], capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        return None
    ids = set()
    for line in (listing.stdout + listing.stderr).splitlines():
        words = line.split()
        if len(words) >= 3 and words[1] == "=":
            ids.add(words[0])
    return ids or None


def command_line(args, avrdude):
    mcu = ax12_fuses.MCUS[args.mcu]
    command = [avrdude, "-p", mcu.part, "-c", args.programmer]
    if args.port:
        command += ["-P", args.port]
    if not args.fuses_only:
        command += ["-U", f"flash:w:{args.hex}:i"]
    for name, value in ax12_fuses.fuses(args.mcu, bootloader=args.with_bootloader).items():
        command += ["-U", f"{name}:w:0x{value:02X}:m"]
    return command


def main(argv=None):
    parser = argparse.ArgumentParser(
        prog="scripts/ax12 flash-isp",
        description="Write the firmware's HEX and the fuses (docs/hardware.md \"Fuses\") to an "
                    "Open AX-12 board through an ISP programmer, with avrdude.")
    parser.add_argument("--programmer", required=True, metavar="NAME",
                        help="avrdude's programmer id (-c), e.g. usbasp, avrisp2, arduino_as_isp; "
                             "`avrdude -c ?` lists them")
    parser.add_argument("--port", metavar="PORT", help="avrdude's -P (serial device, usb, ...)")
    parser.add_argument("--mcu", choices=sorted(ax12_fuses.MCUS), default="atmega88")
    parser.add_argument("--profile", choices=["ax12", "ax12a"], default="ax12")
    parser.add_argument("--hex", metavar="FILE",
                        help="the image to write (default build/firmware/ax12-<profile>-<mcu>-merged.hex on "
                             "a part with a bootloader, else ax12-<profile>-<mcu>.hex)")
    parser.add_argument("--app-only", action="store_true",
                        help="the application alone, BOOTRST unprogrammed (no bootloader: no updates over "
                             "the bus)")
    parser.add_argument("--fuses-only", action="store_true", help="write the fuses only, not the flash")
    parser.add_argument("--dry-run", action="store_true", help="print the avrdude command line, run nothing")
    parser.add_argument("--build", default=os.path.join(REPO, "build"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)

    avrdude = os.environ.get("AX12_AVRDUDE", "avrdude")
    try:
        if args.fuses_only and args.hex:
            raise BadInput("--hex and --fuses-only together: the fuses-only run writes no flash")
        args.with_bootloader = args.mcu in ax12_fuses.BOOTLOADER_MCUS and not args.app_only
        if not args.fuses_only:
            wanted = args.with_bootloader
            if args.hex:
                wanted = False if args.app_only else None
            else:
                suffix = "-merged" if args.with_bootloader else ""
                args.hex = os.path.join(args.build, "firmware", f"ax12-{args.profile}-{args.mcu}{suffix}.hex")
            args.hex = os.path.abspath(args.hex)
            if ":" in os.path.basename(args.hex) or ":" in args.hex:
                raise BadInput(f"{args.hex}: avrdude's -U cannot take a path with ':'")
            args.with_bootloader = check_hex(args.hex, args.mcu, wanted)
        found = shutil.which(avrdude)
        if found is None and not args.dry_run:
            raise BadInput(f"{avrdude} not found: run scripts/setup (Debian package avrdude)")
        if found is not None:
            programmers = known_programmers(found)
            if programmers is not None and args.programmer not in programmers:
                raise BadInput(f"avrdude knows no programmer '{args.programmer}' (`avrdude -c ?` lists them)")
    except BadInput as error:
        print(f"ax12 flash-isp: {error}", file=sys.stderr)
        return 2

    command = command_line(args, avrdude)
    if args.dry_run:
        print(shlex.join(command))
        return 0
    print("ax12 flash-isp: " + shlex.join(command), file=sys.stderr)
    return subprocess.call(command)


if __name__ == "__main__":
    sys.exit(main())
