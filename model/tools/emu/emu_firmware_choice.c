/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "emu_firmware_choice.h"

#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "elf_check.h"
#include "servo_probe.h"
#include "sim_time.h"

#define AVR_WDR 0x95A8u /* the instruction word of WDR */
/* The bootloader's watchdog timeout (docs/bootloader.md "Entry"). */
#define BOOT_WATCHDOG_S 2

static bool project_application(const char *elf) {
  servo_probe_map_t map;
  servo_probe_locate(elf, &map);
  return map.found;
}

/* The default bootloader of o's MCU when it exists, else false. */
static bool default_bootloader(const serve_options_t *o, char *path, size_t len) {
  if (strcmp(o->mcu, "atmega328p") != 0) {
    return false;
  }
  snprintf(path, len, "%s/ax12-boot-%s.elf", o->firmware_dir, o->mcu);
  return access(path, F_OK) == 0; /* not built: the application alone, reset at 0 */
}

void emu_firmware_choose_bootloader(serve_options_t *o) {
  char path[sizeof o->bootloader];
  if (!o->bootloader_given && default_bootloader(o, path, sizeof path) && project_application(o->elf)) {
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
  if (o->bootloader[0] && !elf_flash_has_word(o->elf, AVR_WDR)) {
    fprintf(stderr, "ax12-emu: warning: the bootloader starts the watchdog (%d s) and %s never executes WDR: "
                    "it will be reset every %d s (--bootloader none runs it alone)\n", BOOT_WATCHDOG_S, o->elf,
            BOOT_WATCHDOG_S);
  }
}
