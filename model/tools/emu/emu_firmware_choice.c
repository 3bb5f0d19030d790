/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "emu_firmware_choice.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "boot_image.h"
#include "elf_check.h"
#include "elf_flash.h"
#include "servo_probe.h"
#include "sim_time.h"

static bool project_application(const char *elf) {
  servo_probe_map_t map;
  servo_probe_locate(elf, &map);
  return map.found;
}

/* True when the ELF (checked) ends below the bootloader's application record: built to sit
 * beside it (docs/bootloader.md "Flash layout"; today the ATmega328P's builds). */
static bool leaves_boot_room(const char *elf, const char *mcu) {
  const uint32_t flash_bytes = elf_mcu_flash_bytes(mcu);
  uint8_t *const flash = malloc(flash_bytes ? flash_bytes : 1u);
  uint32_t first = 0;
  uint32_t end = 0;
  char err[256];
  const bool read = flash && flash_bytes && elf_flash_read(elf, flash, flash_bytes, &first, &end, err, sizeof(err));
  free(flash);
  return read && end <= boot_record_address(boot_section_start(flash_bytes));
}

/* The default bootloader of o's MCU when it exists, else false. */
static bool default_bootloader(const serve_options_t *o, char *path, size_t len) {
  snprintf(path, len, "%s/ax12-boot-%s.elf", o->firmware_dir, o->mcu);
  return access(path, F_OK) == 0; /* not built: the application alone, reset at 0 */
}

void emu_firmware_choose_bootloader(serve_options_t *o) {
  char path[sizeof o->bootloader];
  if (!o->bootloader_given && default_bootloader(o, path, sizeof path) && project_application(o->elf) &&
      leaves_boot_room(o->elf, o->mcu)) {
    snprintf(o->bootloader, sizeof o->bootloader, "%s", path);
  }
}

void emu_firmware_say(const serve_options_t *o) {
  if (!project_application(o->elf)) {
    char path[sizeof o->bootloader];
    if (!o->bootloader_given && default_bootloader(o, path, sizeof path)) {
      fprintf(stderr, "ax12-emu: %s is not this project's application: it runs without the bootloader "
                      "(--bootloader %s puts it in front)\n", o->elf, path);
    }
    if (!elf_has_section(o->elf, ".mmcu")) {
      fprintf(stderr, "ax12-emu: %s has no .mmcu section: it runs as an %s at %u MHz (--mcu; build it with "
                      "F_CPU=%uUL)\n", o->elf, o->mcu, (unsigned)(SIM_CPU_HZ / 1000000u), (unsigned)SIM_CPU_HZ);
    }
  }
}
