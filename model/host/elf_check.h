/* SPDX-License-Identifier: GPL-3.0-or-later */
/* Checks that a firmware file is an AVR ELF built for the MCU it is to run on, before simavr
 * loads it: simavr 1.6 crashes on some non-AVR files and loads an ELF of another AVR, or one
 * larger than the flash (it prints a warning and runs a truncated image), into a servo that
 * then never answers. */
#ifndef SIM_ELF_CHECK_H
#define SIM_ELF_CHECK_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* True when path is a 32-bit little-endian ELF for the AVR, of the architecture of mcu
 * ("atmega88": avr4, "atmega328p": avr5), whose loaded bytes fit that MCU's flash. False with
 * a one-line reason in err. */
bool elf_check_avr(const char *path, const char *mcu, char *err, size_t err_len);

/* The flash size of mcu in bytes (0 for an MCU the emulator does not know). */
uint32_t elf_mcu_flash_bytes(const char *mcu);

#endif
