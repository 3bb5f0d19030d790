/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The flash bytes of an AVR ELF at their load addresses, as a programmer would write them
 * (code and the initial values of data: every loadable segment below the EEPROM's 0x810000,
 * placed at its physical address). For an image linked away from address 0, such as a
 * bootloader: simavr 1.6's reader places an ELF by its `__vectors` symbol, which a program
 * built without the C runtime's start files lacks. Check the ELF with elf_check_avr() first. */
#ifndef SIM_ELF_FLASH_H
#define SIM_ELF_FLASH_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* Writes the ELF's flash bytes into flash[0..flash_bytes) (the rest untouched); *first and
 * *end receive the lowest address written and one past the highest. False with a one-line
 * reason in err when the file cannot be read, has no flash bytes, or some lie outside the
 * flash. */
bool elf_flash_read(const char *path, uint8_t *flash, uint32_t flash_bytes, uint32_t *first, uint32_t *end, char *err,
                    size_t err_len);

#endif
