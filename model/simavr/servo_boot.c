/* SPDX-License-Identifier: GPL-3.0-or-later */
#include "servo_boot.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <avr_flash.h>
#include <sim_avr.h>

#include "boot_image.h"
#include "elf_check.h"
#include "elf_flash.h"
#include "servo.h"
#include "servo_flash.h"

bool servo_bootloader_read(servo_bootloader_t *boot, const char *path, const char *mcu, char *err, size_t err_len) {
  memset(boot, 0, sizeof(*boot));
  const uint32_t flash_bytes = elf_mcu_flash_bytes(mcu);
  if (flash_bytes <= BOOT_SECTION_BYTES) {
    snprintf(err, err_len, "unknown MCU '%s'", mcu);
    return false;
  }
  if (!elf_check_avr(path, mcu, err, err_len)) {
    return false;
  }
  boot->flash = malloc(flash_bytes);
  if (!boot->flash) {
    snprintf(err, err_len, "out of memory");
    return false;
  }
  memset(boot->flash, 0xFF, flash_bytes);
  boot->flash_bytes = flash_bytes;
  if (!elf_flash_read(path, boot->flash, flash_bytes, &boot->start, &boot->end, err, err_len)) {
    servo_bootloader_free(boot);
    return false;
  }
  const uint32_t section = flash_bytes - BOOT_SECTION_BYTES;
  if (boot->start != section) {
    snprintf(err, err_len,
             "bootloader %s starts at 0x%04lx, not at the boot section's start 0x%04lx (link it with "
             "-Wl,--section-start=.text=0x%lx)",
             path, (unsigned long)boot->start, (unsigned long)section, (unsigned long)section);
    servo_bootloader_free(boot);
    return false;
  }
  return true;
}

void servo_bootloader_free(servo_bootloader_t *boot) {
  free(boot->flash);
  memset(boot, 0, sizeof(*boot));
}

int servo_boot_attach(servo_t *servo, const servo_bootloader_t *boot, uint32_t app_bytes, char *err,
                      size_t err_len) {
  avr_t *avr = servo->avr;
  const uint32_t flash_bytes = avr->flashend + 1u;
  if (boot->flash_bytes != flash_bytes || !servo_flash_module(avr)) {
    snprintf(err, err_len, "the bootloader was read for %lu B of flash, the MCU has %lu",
             (unsigned long)boot->flash_bytes, (unsigned long)flash_bytes);
    return -1;
  }
  const uint16_t record_at = boot_record_address((uint16_t)boot->start);
  if (app_bytes == 0 || app_bytes > record_at) {
    snprintf(err, err_len, "the application (%lu B) reaches into the application record at 0x%04x",
             (unsigned long)app_bytes, record_at);
    return -1;
  }
  memcpy(avr->flash + boot->start, boot->flash + boot->start, boot->end - boot->start);
  boot_record_build(avr->flash + record_at, app_bytes, boot_check_bytes(0, avr->flash, app_bytes));
  /* BOOTRST: simavr 1.6's avr_reset() sets the PC (a byte address) to reset_pc. It also zeroes
   * every I/O register and leaves SRAM as it was, as silicon does. avr_init() ran its reset
   * already: the first start too. */
  avr->reset_pc = boot->start;
  avr->pc = boot->start;
  return 0;
}
