/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The servos of `ax12-emu serve --ids LIST` added to the world, each on its EEPROM state file
 * in --state-dir (docs/emulator.md "State files"):
 *
 * - The file is locked first (state_lock.h): a second emulator on the same state directory
 *   stops with "in use by another ax12-emu (pid N)". The locks are held until the serve loop
 *   has written the last state file.
 * - A state file that holds no valid settings image, or is not an EEPROM of this MCU's size, is
 *   kept aside under another name (never overwritten) with a one-line warning; the servo runs
 *   on its bytes, so it boots as its firmware decides (factory defaults when no slot is valid),
 *   and its state file starts again from them.
 * - Where a servo's flash came from, when not from the ELFs alone (an update it was flashed
 *   with, or such an image dropped), is one line on stderr. */
#ifndef EMU_STATE_FILES_H
#define EMU_STATE_FILES_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "emu_options.h"
#include "world.h"

/* The state files' locks held (file descriptors of state_lock_take, with the slot each is for). */
typedef struct {
  int fds[ID_LIST_MAX_ID + 1u];
  uint8_t slots[ID_LIST_MAX_ID + 1u];
  size_t count;
  const char *state_dir;
} emu_state_locks_t;

/* Adds one servo per ID of o->ids, at o->baud_register when its state file has none, as above; locks
 * starts empty. False after one line on stderr ("ax12-emu: servo N: why") when a file is
 * locked by another emulator, a servo cannot be made, or a bad state file cannot be kept
 * aside; the locks taken are then released (the world keeps the servos added). */
bool emu_state_files_add_servos(world_t *world, const serve_options_t *o, emu_state_locks_t *locks);

/* Releases every lock and removes its lock file (after the last state file was written). */
void emu_state_locks_release(emu_state_locks_t *locks);

#endif
