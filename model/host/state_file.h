/* SPDX-License-Identifier: GPL-3.0-or-later */
/* Replacing a state file atomically (the EEPROM's, eeprom_store.h; the flash's, flash_store.h):
 * the new contents go to a temporary file in the same directory, which is then renamed over
 * the old one. Killing the emulator at any moment leaves the old contents or the new, never a
 * mix (the kernel keeps what was written). */
#ifndef SIM_STATE_FILE_H
#define SIM_STATE_FILE_H

#include <stddef.h>
#include <sys/types.h>

/* state_file_open()'s answer when path does not exist. */
#define STATE_FILE_ABSENT (-2)

/* Opens path for reading; it must be a regular file (a FIFO is refused without waiting for a
 * writer). Returns the descriptor with *size set, STATE_FILE_ABSENT, or -1 with err set. */
int state_file_open(const char *path, off_t *size, char *err, size_t err_len);

/* Replaces path with data[0..size) atomically. Returns 0, or -1 with err set. While writes go
 * behind (state_write_behind.h), queues a copy instead and returns at once (-1 then reports a
 * write behind that failed). */
int state_file_replace(const char *path, const void *data, size_t size, char *err, size_t err_len);

/* Replaces path now, in the calling thread, whatever state_write_behind says. */
int state_file_replace_now(const char *path, const void *data, size_t size, char *err, size_t err_len);

#endif
