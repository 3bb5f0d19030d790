/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "elf_symbols.h"

#include <fcntl.h>
#include <gelf.h>
#include <libelf.h>
#include <string.h>
#include <unistd.h>

#define AVR_DATA_OFFSET 0x800000u

/* name itself, or a compiler clone of it: name.constprop.N, name.lto_priv.N, name.part.N */
static bool symbol_matches(const char *sym_name, const char *name) {
  const size_t len = strlen(name);
  return strncmp(sym_name, name, len) == 0 && (sym_name[len] == '\0' || sym_name[len] == '.');
}

bool elf_symbol_address(const char *elf_path, const char *name, uint32_t *address) {
  if (elf_version(EV_CURRENT) == EV_NONE) {
    return false;
  }
  const int fd = open(elf_path, O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    return false;
  }
  bool found = false;
  Elf *elf = elf_begin(fd, ELF_C_READ, NULL);
  Elf_Scn *scn = NULL;
  while (elf && !found && (scn = elf_nextscn(elf, scn)) != NULL) {
    GElf_Shdr shdr;
    if (!gelf_getshdr(scn, &shdr) || shdr.sh_type != SHT_SYMTAB || shdr.sh_entsize == 0) {
      continue;
    }
    Elf_Data *data = elf_getdata(scn, NULL);
    const size_t n = shdr.sh_size / shdr.sh_entsize;
    for (size_t i = 0; data && i < n; i++) {
      GElf_Sym sym;
      if (!gelf_getsym(data, (int)i, &sym)) {
        continue;
      }
      const char *sym_name = elf_strptr(elf, shdr.sh_link, sym.st_name);
      if (sym_name && symbol_matches(sym_name, name)) {
        uint32_t value = (uint32_t)sym.st_value;
        if (value >= AVR_DATA_OFFSET && value < AVR_DATA_OFFSET + 0x10000u) {
          value -= AVR_DATA_OFFSET;
        }
        *address = value;
        found = true;
        break;
      }
    }
  }
  if (elf) {
    elf_end(elf);
  }
  close(fd);
  return found;
}

bool elf_ram_end_of_statics(const char *elf_path, uint16_t *address) {
  static const char *const names[] = {"_end", "__heap_start", "__bss_end"};
  for (size_t i = 0; i < sizeof(names) / sizeof(names[0]); i++) {
    uint32_t value;
    if (elf_symbol_address(elf_path, names[i], &value)) {
      *address = (uint16_t)value;
      return true;
    }
  }
  return false;
}
