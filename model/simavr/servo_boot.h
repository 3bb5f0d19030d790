/* SPDX-License-Identifier: GPL-3.0-or-later */
/* A servo's flash at power-up when it carries a bootloader: the application ELF's bytes from
 * address 0, the application record in the page below the boot section, the bootloader's bytes
 * in the boot section, and every reset starting there, as on a board programmed with the merged
 * HEX and the BOOTRST fuse (docs/bootloader.md "Flash layout", docs/hardware.md "Fuses"). */
#ifndef SIM_SERVO_BOOT_H
#define SIM_SERVO_BOOT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

struct servo;

/* A bootloader ELF's flash bytes, read once for every servo of a world. */
typedef struct servo_bootloader {
  uint8_t *flash;       /* a whole flash image, 0xFF but for the bootloader's bytes */
  uint32_t flash_bytes; /* the MCU's flash size */
  uint32_t start, end;  /* its bytes: [start, end); start is the boot section's first byte */
} servo_bootloader_t;

/* Reads the bootloader ELF at path for mcu ("atmega328p"...): an AVR ELF of that MCU whose
 * bytes start at the boot section (the top BOOT_SECTION_BYTES of flash, boot_image.h) and lie
 * within it. False with a one-line reason in err. */
bool servo_bootloader_read(servo_bootloader_t *boot, const char *path, const char *mcu, char *err, size_t err_len);
void servo_bootloader_free(servo_bootloader_t *boot);

/* At servo_create, the application ELF loaded (app_bytes: its .text + .data from address 0,
 * simavr's flashsize): copies the bootloader's bytes, writes the application record
 * (boot_record_build with the check value of flash bytes 0 .. app_bytes - 1) and makes every
 * reset (power-up, watchdog, servo_reset) start at the boot section. -1 with err set when the
 * bootloader is for another flash size or the application reaches into the record. */
int servo_boot_attach(struct servo *servo, const servo_bootloader_t *boot, uint32_t app_bytes, char *err,
                      size_t err_len);

#endif
