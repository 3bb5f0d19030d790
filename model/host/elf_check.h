/* SPDX-License-Identifier: GPL-3.0-or-later */
/* Checks that a firmware file is an AVR ELF built for the MCU it is to run on, before simavr
 * loads it: simavr 1.6 crashes on some non-AVR files and loads an ELF of another AVR, or one
 * larger than the flash (it prints a warning and runs a truncated image), into a servo that
 * then never answers. */
#ifndef SIM_ELF_CHECK_H
#define SIM_ELF_CHECK_H

#include <elf.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

/* Addresses of an AVR ELF: flash below 0x800000, SRAM from there (.data, loaded from flash at
 * its physical address), EEPROM from 0x810000. */
#define ELF_AVR_EEPROM_SPACE 0x810000u

/* Opens path and reads its ELF header into *h: a 32-bit little-endian ELF for the AVR. NULL with
 * a one-line reason in err otherwise. */
FILE *elf_open_avr(const char *path, Elf32_Ehdr *h, char *err, size_t err_len);

/* Reads program header i of the ELF f (header h). False with err set when the file is cut short. */
bool elf_program_header(FILE *f, const Elf32_Ehdr *h, unsigned i, Elf32_Phdr *ph, const char *path, char *err,
                        size_t err_len);

/* True when path is a 32-bit little-endian ELF for the AVR, of the architecture of mcu
 * ("atmega88": avr4, "atmega328p": avr5), whose loaded bytes fit that MCU's flash. False with
 * a one-line reason in err. */
bool elf_check_avr(const char *path, const char *mcu, char *err, size_t err_len);

/* Whether the ELF at path has a section called name (e.g. ".mmcu", where simavr's
 * avr_mcu_section.h puts the MCU and clock a program was built for). */
bool elf_has_section(const char *path, const char *name);

/* The flash size of mcu in bytes (0 for an MCU the emulator does not know). */
uint32_t elf_mcu_flash_bytes(const char *mcu);

#endif
