/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "elf_check.h"

#include <elf.h>
#include <errno.h>
#include <stdlib.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

/* Where data space starts in an AVR ELF's addresses: flash lies below. */
#define ELF_AVR_DATA_SPACE 0x800000u

/* e_flags of an AVR ELF: the architecture number in its low 7 bits (binutils' EF_AVR_MACH). */
#define AVR_MACH_MASK 0x7Fu

typedef struct {
  const char *mcu;
  unsigned arch;
  uint32_t flash_bytes;
} mcu_facts_t;

static const mcu_facts_t MCUS[] = {
    {"atmega88", 4, 8192},
    {"atmega328p", 5, 32768},
};

static const mcu_facts_t *facts_of(const char *mcu) {
  for (size_t i = 0; i < sizeof MCUS / sizeof MCUS[0]; i++) {
    if (strcmp(MCUS[i].mcu, mcu) == 0) {
      return &MCUS[i];
    }
  }
  return NULL;
}

uint32_t elf_mcu_flash_bytes(const char *mcu) {
  const mcu_facts_t *facts = facts_of(mcu);
  return facts ? facts->flash_bytes : 0;
}

static const char *mcu_of_arch(unsigned arch) {
  for (size_t i = 0; i < sizeof MCUS / sizeof MCUS[0]; i++) {
    if (MCUS[i].arch == arch) {
      return MCUS[i].mcu;
    }
  }
  return NULL;
}

FILE *elf_open_avr(const char *path, Elf32_Ehdr *h, char *err, size_t err_len) {
  FILE *f = fopen(path, "rb");
  if (!f) {
    snprintf(err, err_len, "cannot read %s: %s", path, strerror(errno));
    return NULL;
  }
  const bool ok = fread(h, sizeof *h, 1, f) == 1 && memcmp(h->e_ident, ELFMAG, SELFMAG) == 0;
  if (!ok || h->e_ident[EI_CLASS] != ELFCLASS32 || h->e_ident[EI_DATA] != ELFDATA2LSB || h->e_machine != EM_AVR) {
    snprintf(err, err_len, "%s is not an AVR firmware ELF", path);
    fclose(f);
    return NULL;
  }
  return f;
}

bool elf_program_header(FILE *f, const Elf32_Ehdr *h, unsigned i, Elf32_Phdr *ph, const char *path, char *err,
                        size_t err_len) {
  if (fseek(f, (long)(h->e_phoff + (uint64_t)i * h->e_phentsize), SEEK_SET) != 0 || fread(ph, sizeof *ph, 1, f) != 1) {
    snprintf(err, err_len, "%s: truncated ELF program header", path);
    return false;
  }
  return true;
}

bool elf_check_avr(const char *path, const char *mcu, char *err, size_t err_len) {
  const mcu_facts_t *facts = facts_of(mcu);
  if (!facts) {
    snprintf(err, err_len, "unknown MCU '%s'", mcu);
    return false;
  }
  Elf32_Ehdr h;
  FILE *f = elf_open_avr(path, &h, err, err_len);
  if (!f) {
    return false;
  }
  const unsigned arch = h.e_flags & AVR_MACH_MASK;
  if (arch != facts->arch) {
    const char *other = mcu_of_arch(arch);
    if (other) {
      snprintf(err, err_len, "%s is built for the %s, not the %s (--mcu %s)", path, other, mcu, other);
    } else {
      snprintf(err, err_len, "%s is built for AVR architecture %u, not the %s's (%u)", path, arch, mcu,
               facts->arch);
    }
    fclose(f);
    return false;
  }
  uint64_t flash = 0;
  for (unsigned i = 0; i < h.e_phnum; i++) {
    Elf32_Phdr ph;
    if (!elf_program_header(f, &h, i, &ph, path, err, err_len)) {
      fclose(f);
      return false;
    }
    /* Code, and the initial values of data, which the C runtime copies from flash. */
    if (ph.p_type == PT_LOAD && ph.p_vaddr < ELF_AVR_EEPROM_SPACE) {
      flash += ph.p_filesz;
    }
  }
  fclose(f);
  if (flash > facts->flash_bytes) {
    snprintf(err, err_len, "%s needs %llu B of flash; the %s has %u", path, (unsigned long long)flash, mcu,
             (unsigned)facts->flash_bytes);
    return false;
  }
  return true;
}

/* elf_open_avr for a question whose answer is "no" when the file cannot be read. */
static FILE *open_for_a_question(const char *path, Elf32_Ehdr *h) {
  char err[160];
  return elf_open_avr(path, h, err, sizeof err);
}

bool elf_has_section(const char *path, const char *name) {
  Elf32_Ehdr h;
  FILE *f = open_for_a_question(path, &h);
  if (!f) {
    return false;
  }
  bool found = false;
  Elf32_Shdr names;
  if (h.e_shstrndx != SHN_UNDEF && h.e_shstrndx < h.e_shnum &&
      fseek(f, (long)(h.e_shoff + (uint64_t)h.e_shstrndx * h.e_shentsize), SEEK_SET) == 0 &&
      fread(&names, sizeof names, 1, f) == 1) {
    const size_t len = strlen(name);
    char *buf = malloc(len + 1u);
    for (unsigned i = 0; buf && i < h.e_shnum && !found; i++) {
      Elf32_Shdr sh;
      if (fseek(f, (long)(h.e_shoff + (uint64_t)i * h.e_shentsize), SEEK_SET) != 0 || fread(&sh, sizeof sh, 1, f) != 1 ||
          sh.sh_name >= names.sh_size) {
        continue;
      }
      if (fseek(f, (long)(names.sh_offset + sh.sh_name), SEEK_SET) == 0 && fread(buf, 1, len + 1u, f) == len + 1u &&
          memcmp(buf, name, len + 1u) == 0) {
        found = true;
      }
    }
    free(buf);
  }
  fclose(f);
  return found;
}
