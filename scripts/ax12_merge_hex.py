#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Writes the whole flash of a new board as one Intel HEX: the application's HEX, its
application record and the bootloader's HEX (docs/bootloader.md "Flash layout";
python/ax12_app_image.py). Run by the build (cmake/firmware.cmake) for every application that
sits beside the bootloader (firmware/bootable_mcus.cmake):

    ax12_merge_hex.py --mcu atmega328p APP.hex BOOT.hex OUT.hex

When BOOT.hex does not exist (the bootloader is not built) it writes nothing, removes a stale
OUT.hex and says so on stderr: exit 0. OUT.hex is rewritten only when its bytes change.
Exit status: 0 written or skipped; 2 a file that cannot be merged (the reason on stderr).
"""

import argparse
import io
import os
import sys

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "python"))

import ax12_app_image  # noqa: E402
import ax12_fuses  # noqa: E402


def main(argv=None):
    parser = argparse.ArgumentParser(prog="ax12_merge_hex.py", description=__doc__.split("\n\n")[0])
    parser.add_argument("--mcu", choices=[name for name, mcu in ax12_fuses.MCUS.items()
                                          if mcu.app_limit_bytes < mcu.flash_bytes], required=True)
    parser.add_argument("app", metavar="APP.hex")
    parser.add_argument("boot", metavar="BOOT.hex")
    parser.add_argument("out", metavar="OUT.hex")
    args = parser.parse_args(argv)

    if not os.path.exists(args.boot):
        if os.path.exists(args.out):
            os.remove(args.out)
        print(f"ax12_merge_hex: {args.boot} not built: no {os.path.basename(args.out)}", file=sys.stderr)
        return 0
    try:
        merged = ax12_app_image.merged_hex(ax12_app_image.load(args.app), args.boot, args.mcu)
    except ax12_app_image.ImageError as error:
        print(f"ax12_merge_hex: {error}", file=sys.stderr)
        return 2
    text = io.StringIO()
    merged.write_hex_file(text, write_start_addr=False)
    text = text.getvalue()
    try:
        with open(args.out) as f:
            if f.read() == text:
                return 0
    except OSError:
        pass
    with open(args.out + ".tmp", "w") as f:
        f.write(text)
    os.replace(args.out + ".tmp", args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
