/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "elf_flash.h"

#include <elf.h>
#include <errno.h>
#include <stdio.h>
#include <string.h>

/* Virtual addresses of an AVR ELF: flash below 0x800000, SRAM from there (.data, loaded from
 * flash at its physical address), EEPROM from 0x810000. */
#define AVR_EEPROM_SPACE 0x810000u

bool elf_flash_read(const char *path, uint8_t *flash, uint32_t flash_bytes, uint32_t *first, uint32_t *end, char *err,
                    size_t err_len) {
  FILE *f = fopen(path, "rb");
  if (!f) {
    snprintf(err, err_len, "cannot read %s: %s", path, strerror(errno));
    return false;
  }
  Elf32_Ehdr h;
  if (fread(&h, sizeof h, 1, f) != 1 || memcmp(h.e_ident, ELFMAG, SELFMAG) != 0 || h.e_machine != EM_AVR) {
    snprintf(err, err_len, "%s is not an AVR firmware ELF", path);
    fclose(f);
    return false;
  }
  uint32_t lowest = UINT32_MAX, highest = 0;
  for (unsigned i = 0; i < h.e_phnum; i++) {
    Elf32_Phdr ph;
    if (fseek(f, (long)(h.e_phoff + (uint64_t)i * h.e_phentsize), SEEK_SET) != 0 || fread(&ph, sizeof ph, 1, f) != 1) {
      snprintf(err, err_len, "%s: truncated ELF program header", path);
      fclose(f);
      return false;
    }
    if (ph.p_type != PT_LOAD || ph.p_filesz == 0 || ph.p_vaddr >= AVR_EEPROM_SPACE) {
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
