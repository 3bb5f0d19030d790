/* SPDX-License-Identifier: GPL-3.0-or-later */
#define _GNU_SOURCE
#include "emu_state_files.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <string.h>

#include "eeprom_store.h"
#include "servo.h"
#include "state_lock.h"

/* A state file that is no valid settings image of this MCU is kept aside (see the header).
 * False (err set) only when that fails. */
static bool check_state_file(servo_t *servo, const char *path, unsigned id, char *err, size_t err_len) {
  char why[160];
  if (eeprom_store_file_fits(path, servo->eeprom_size, why, sizeof why)) {
    if (eeprom_store_image_fields(servo->eeprom, servo->eeprom_size, NULL, NULL)) {
      if (eeprom_store_cut_slot(servo->eeprom, servo->eeprom_size)) {
        fprintf(stderr,
                "ax12-emu: warning: servo %u: the newer settings in %s fail their check (a store cut by a power "
                "loss or a kill, or a damaged file): it boots the settings stored before them\n",
                id, path);
      }
      return true;
    }
    snprintf(why, sizeof why, "no valid settings image");
  }
  char aside[PATH_MAX + 64];
  if (eeprom_store_set_aside(path, aside, sizeof aside) != 0) {
    const int why_not = errno;
    const int n = snprintf(err, err_len, "%s: %s, and it cannot be kept aside: ", path, why);
    if (n >= 0 && (size_t)n < err_len) {
      snprintf(err + n, err_len - (size_t)n, "%s", strerror(why_not));
    }
    return false;
  }
  const bool has_settings = eeprom_store_image_fields(servo->eeprom, servo->eeprom_size, NULL, NULL);
  fprintf(stderr, "ax12-emu: warning: servo %u: %s: %s; kept as %s; the servo boots %s\n", id, path, why, aside,
          has_settings ? "with the settings in it" : "as its firmware decides (factory defaults, ID 1)");
  return eeprom_store_save(path, servo->eeprom, servo->eeprom_size, err, err_len) == 0;
}

/* Where servo `id`'s flash came from, when not from the ELFs alone: one line on stderr. */
static void report_flash_origin(const servo_t *servo, unsigned id, const char *mcu) {
  switch (servo->flash_origin) {
  case SERVO_FLASH_FROM_STATE:
    fprintf(stderr, "ax12-emu: servo %u runs the flash it was updated to (%s)\n", id, servo->flash_path);
    break;
  case SERVO_FLASH_DROPPED_OTHER_BUILD:
    fprintf(stderr, "ax12-emu: the firmware was rebuilt: servo %u's flashed image is dropped (%s removed)\n", id,
            servo->flash_path);
    break;
  case SERVO_FLASH_DROPPED_INVALID:
    fprintf(stderr, "ax12-emu: warning: servo %u: %s is not a flash image of the %s: dropped (removed)\n", id,
            servo->flash_path, mcu);
    break;
  case SERVO_FLASH_FROM_ELF:
    break;
  }
}

bool emu_state_files_add_servos(world_t *world, const serve_options_t *o, emu_state_locks_t *locks) {
  char err[512];
  locks->count = 0;
  locks->state_dir = o->state_dir;
  for (size_t i = 0; i < o->id_count; i++) {
    char path[PATH_MAX + 32];
    eeprom_store_path(path, sizeof(path), o->state_dir, o->ids[i]);
    const int lock = state_lock_take(path, err, sizeof(err));
    servo_t *servo = lock < 0 ? NULL : world_add_servo(world, o->ids[i], (uint8_t)o->baud_register, path, err, sizeof(err));
    if (lock >= 0) {
      locks->slots[locks->count] = o->ids[i];
      locks->fds[locks->count++] = lock;
    }
    if (!servo || !check_state_file(servo, path, o->ids[i], err, sizeof(err))) {
      fprintf(stderr, "ax12-emu: servo %u: %s\n", o->ids[i], err);
      emu_state_locks_release(locks);
      return false;
    }
    report_flash_origin(servo, o->ids[i], o->mcu);
  }
  return true;
}

void emu_state_locks_release(emu_state_locks_t *locks) {
  for (size_t i = 0; i < locks->count; i++) {
    char path[PATH_MAX + 32];
    eeprom_store_path(path, sizeof(path), locks->state_dir, locks->slots[i]);
    state_lock_release(locks->fds[i], path);
  }
  locks->count = 0;
}
