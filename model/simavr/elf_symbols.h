/* SPDX-License-Identifier: GPL-3.0-or-later */
/* Symbol addresses from an AVR ELF (libelf), e.g. `_end` for the stack probe. Data addresses
 * are returned as RAM addresses (the linker's 0x800000 offset removed). */
#ifndef SIM_ELF_SYMBOLS_H
#define SIM_ELF_SYMBOLS_H

#include <stdbool.h>
#include <stdint.h>

/* Looks `name` up in the ELF's symbol table (or a compiler clone of it: `name.constprop.N`,
 * `name.lto_priv.N`...). */
bool elf_symbol_address(const char *elf_path, const char *name, uint32_t *address);

/* The first RAM address after .data/.bss/.noinit: `_end` (or `__heap_start`, `__bss_end`). */
bool elf_ram_end_of_statics(const char *elf_path, uint16_t *address);

#endif
