/* SPDX-License-Identifier: GPL-3.0-or-later */
/* A servo's flash as a state file (`<state-dir>/servo-<n>.flash`, beside its `.eeprom`): the
 * flash after the firmware changed it with SPM (a bootloader's update), with the identity of
 * the build the servo started from. Pure C.
 *
 * File: a 24-byte header, then the whole flash, byte for byte.
 *   0   "AX12FLSH"
 *   8   flash size in bytes (32 bits, little-endian)
 *   12  format version, 1 (32 bits, LE)
 *   16  build identity (64 bits, LE): flash_store_identity() of the flash as the ELFs load it
 *       (application, bootloader and its application record), before any SPM
 * A file is used only when its identity and size are those of the build loaded now: a rebuilt
 * firmware drops the flashed image. Written atomically (state_file.h). */
#ifndef SIM_FLASH_STORE_H
#define SIM_FLASH_STORE_H

#include <stddef.h>
#include <stdint.h>

#define FLASH_STORE_HEADER_BYTES 24u
#define FLASH_STORE_VERSION 1u

typedef enum {
  FLASH_STORE_ABSENT = 0,      /* no file */
  FLASH_STORE_LOADED = 1,      /* read: the flash now holds it */
  FLASH_STORE_OTHER_BUILD = 2, /* a flash image of another build (the firmware was rebuilt) */
  FLASH_STORE_INVALID = 3,     /* not a flash image of this MCU (header, size) */
} flash_store_status_t;

/* The identity of a build: FNV-1a (64 bits) of its flash bytes. */
uint64_t flash_store_identity(const uint8_t *flash, size_t size);

/* Reads path into flash[0..size) when it is an image of that size with this identity (flash
 * is left alone otherwise). Returns a status, or -1 with err set when the file cannot be read
 * (which includes a path that is not a regular file). */
int flash_store_load(const char *path, uint64_t identity, uint8_t *flash, size_t size, char *err, size_t err_len);

/* Replaces path with the header and flash[0..size) atomically. 0, or -1 with err set. */
int flash_store_save(const char *path, uint64_t identity, const uint8_t *flash, size_t size, char *err,
                     size_t err_len);

/* The flash file beside an EEPROM state file: "<dir>/servo-<n>.eeprom" -> "<dir>/servo-<n>.flash"
 * (any other name: "<name>.flash"). */
void flash_store_path_beside(char *out, size_t out_len, const char *eeprom_path);

#endif
