/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "elf_flash.h"

#include <stdio.h>

#include "elf_check.h"

bool elf_flash_read(const char *path, uint8_t *flash, uint32_t flash_bytes, uint32_t *first, uint32_t *end, char *err,
                    size_t err_len) {
  Elf32_Ehdr h;
  FILE *f = elf_open_avr(path, &h, err, err_len);
  if (!f) {
    return false;
  }
  uint32_t lowest = UINT32_MAX, highest = 0;
  for (unsigned i = 0; i < h.e_phnum; i++) {
    Elf32_Phdr ph;
    if (!elf_program_header(f, &h, i, &ph, path, err, err_len)) {
      fclose(f);
      return false;
    }
    if (ph.p_type != PT_LOAD || ph.p_filesz == 0 || ph.p_vaddr >= ELF_AVR_EEPROM_SPACE) {
      continue;
    }
    if ((uint64_t)ph.p_paddr + ph.p_filesz > flash_bytes) {
      snprintf(err, err_len, "%s: bytes at 0x%lx..0x%lx lie outside the %lu B of flash", path,
               (unsigned long)ph.p_paddr, (unsigned long)(ph.p_paddr + ph.p_filesz - 1u), (unsigned long)flash_bytes);
      fclose(f);
      return false;
    }
    if (fseek(f, (long)ph.p_offset, SEEK_SET) != 0 || fread(flash + ph.p_paddr, 1, ph.p_filesz, f) != ph.p_filesz) {
      snprintf(err, err_len, "%s: truncated ELF segment", path);
      fclose(f);
      return false;
    }
    if (ph.p_paddr < lowest) {
      lowest = ph.p_paddr;
    }
    if (ph.p_paddr + ph.p_filesz > highest) {
      highest = ph.p_paddr + ph.p_filesz;
    }
  }
  fclose(f);
  if (highest == 0) {
    snprintf(err, err_len, "%s holds no flash bytes", path);
    return false;
  }
  *first = lowest;
  *end = highest;
  return true;
}
