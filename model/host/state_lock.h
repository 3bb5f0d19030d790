/* SPDX-License-Identifier: GPL-3.0-or-later */
/* One emulator per state file: a servo's state file is held for as long as an emulator runs
 * it, through an flock on "<state file>.lock" (the state file itself is replaced by rename at
 * every write, so it cannot carry the lock). The lock file holds the holder's PID, for the
 * message a second emulator gets. The kernel drops the lock when the holder exits, however
 * it exits (a SIGKILL included). */
#ifndef SIM_STATE_LOCK_H
#define SIM_STATE_LOCK_H

#include <stddef.h>

/* Takes the lock of state_path. Returns its file descriptor (kept open while running), or -1
 * with a one-line reason in err: "<state file> is in use by another ax12-emu (pid N)". */
int state_lock_take(const char *state_path, char *err, size_t err_len);

/* Releases a lock taken by state_lock_take (the lock file stays: removing it would race with
 * a second emulator taking it). */
void state_lock_release(int fd);

#endif
