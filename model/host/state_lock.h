/* SPDX-License-Identifier: GPL-3.0-or-later */
/* One emulator per state file: a servo's state file is held for as long as an emulator runs
 * it, through an flock on "<state file>.lock" (the state file itself is replaced by rename at
 * every write, so it cannot carry the lock). The lock file holds the holder's PID, for the
 * message a second emulator gets. The kernel drops the lock when the holder exits, however
 * it exits (a SIGKILL included: the lock file then stays, and the next emulator takes it). */
#ifndef SIM_STATE_LOCK_H
#define SIM_STATE_LOCK_H

#include <stddef.h>

/* Takes the lock of state_path. Returns its file descriptor (kept open while running), or -1
 * with a one-line reason in err: "<state file> is in use by another ax12-emu (pid N)". The
 * lock is on the file the path names when it is taken: a lock file removed by its holder's
 * release meanwhile (an emulator stopping just then) is not taken, a new one is. */
int state_lock_take(const char *state_path, char *err, size_t err_len);

/* Releases a lock taken by state_lock_take for state_path and removes its lock file (while
 * still holding it, so that whoever opened that file meanwhile sees it gone and makes a new
 * one: state_lock_take). */
void state_lock_release(int fd, const char *state_path);

#endif
