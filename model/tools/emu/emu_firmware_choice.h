/* SPDX-License-Identifier: GPL-3.0-or-later */
/* Which bootloader `serve` puts in front of the application, and what it says about a program
 * that is not this project's application (docs/conform.md "Testing your own firmware on the
 * emulated bus"). */
#ifndef EMU_FIRMWARE_CHOICE_H
#define EMU_FIRMWARE_CHOICE_H

#include "emu_options.h"

/* When no --bootloader was given: the default one (<firmware-dir>/ax12-boot-<mcu>.elf, when it
 * exists) goes in front of this project's application only: an ELF with the `servo` object the
 * dashboard reads (servo_probe.h) that ends below the application record (this project's
 * builds, on both parts). Another program runs alone. */
void emu_firmware_choose_bootloader(serve_options_t *o);

/* Once the firmware and the bootloader are loaded, on stderr: that a program not of this project runs without the
 * default bootloader, and what was assumed for an ELF without a .mmcu section (the MCU of --mcu
 * at the board's 16 MHz). */
void emu_firmware_say(const serve_options_t *o);

#endif
