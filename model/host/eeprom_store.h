/* SPDX-License-Identifier: GPL-3.0-or-later */
/* A servo's EEPROM as a state file (`<state-dir>/servo-<n>.eeprom`): the whole EEPROM of the
 * MCU, byte for byte (512 bytes on the ATmega88). Pure C; the image format is the
 * firmware's (firmware/core/dxl_image.h, docs/hardware.md "EEPROM image").
 *
 * A file is replaced atomically (state_file.h): killing the emulator at any point leaves either
 * the old or the new contents, never a mix. */
#ifndef SIM_EEPROM_STORE_H
#define SIM_EEPROM_STORE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef enum { EEPROM_PROFILE_AX12 = 0, EEPROM_PROFILE_AX12A = 1 } eeprom_profile_t;

/* Parses "ax12" / "ax12a". */
bool eeprom_profile_parse(const char *name, eeprom_profile_t *profile);
const char *eeprom_profile_name(eeprom_profile_t profile);

/* A blank EEPROM (0xFF) holding, from address 0, an image (dxl_image_build: slot 0) of the
 * profile's factory EEPROM area with ID and Baud Rate replaced. */
void eeprom_store_seed(uint8_t *eeprom, size_t size, eeprom_profile_t profile, uint8_t id, uint8_t baud_reg);

/* True when the EEPROM holds a valid image; then *id and *baud_reg (if not NULL) receive the
 * ID and Baud Rate of its newest valid slot, as stored. */
bool eeprom_store_image_fields(const uint8_t *eeprom, size_t size, uint8_t *id, uint8_t *baud_reg);

/* True when one slot of the EEPROM's image is valid and the other is neither valid nor blank
 * (erased, 0xFF): the settings being stored into that one did not all get there (a store cut
 * by a power loss or a kill, or a damaged file), so the servo boots the valid one, the
 * settings stored before. */
bool eeprom_store_cut_slot(const uint8_t *eeprom, size_t size);

/* Reads path into eeprom[0..size): a shorter file leaves the rest blank (0xFF), a longer one
 * is cut. Returns 1 when read, 0 when the file does not exist, -1 on error (err set), which
 * includes a path that is not a regular file (a FIFO is refused without waiting for it). */
int eeprom_store_load(const char *path, uint8_t *eeprom, size_t size, char *err, size_t err_len);

/* Replaces path with eeprom[0..size) atomically. Returns 0, or -1 with err set. */
int eeprom_store_save(const char *path, const uint8_t *eeprom, size_t size, char *err, size_t err_len);

/* False when path exists with another size than an EEPROM of size bytes (why says so). */
bool eeprom_store_file_fits(const char *path, size_t size, char *why, size_t why_len);

/* Renames path to "<path>.invalid-<n>" with the first n not taken (the name in aside). 0, or
 * -1 with errno. */
int eeprom_store_set_aside(const char *path, char *aside, size_t aside_len);

/* The state file of slot n in dir: "<dir>/servo-<n>.eeprom". */
void eeprom_store_path(char *out, size_t out_len, const char *dir, unsigned n);

#endif
