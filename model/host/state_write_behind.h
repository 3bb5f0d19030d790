/* SPDX-License-Identifier: GPL-3.0-or-later */
/* State files written behind the simulation (`serve` in real time): while started, every
 * state_file_replace() copies its data into a queue and returns at once, and a thread of the
 * ordinary scheduling policy writes it (state_file_replace_now). A rename on a busy disk can
 * take over a second, far longer than any client's timeout: the thread that paces the
 * simulation must never wait for one.
 *
 * A newer image of a path replaces one still queued for it (the files hold whole images: the
 * newest is the one to keep). Each file is still replaced atomically, so a kill leaves its old
 * contents or a newer whole image; what was queued and not yet written when the process is
 * killed is lost, as an EEPROM write not yet stored is on a real servo. A write that fails is
 * reported by the next state_file_replace() (its error, -1) and by state_write_behind_flush(). */
#ifndef SIM_STATE_WRITE_BEHIND_H
#define SIM_STATE_WRITE_BEHIND_H

#include <stdbool.h>
#include <stddef.h>

/* Starts the writing thread. 0, or -1 with err set (then writes stay synchronous). */
int state_write_behind_start(char *err, size_t err_len);

/* True while started: state_file_replace() queues. */
bool state_write_behind_active(void);

/* Queues a copy of data for path (state_file_replace calls it). -1 with err set when a write
 * behind failed since the last report (the error is reported once), or when out of memory
 * (then nothing is queued); else 0. */
int state_write_behind_queue(const char *path, const void *data, size_t size, char *err, size_t err_len);

/* Waits until everything queued so far is written. Returns the number of writes that failed
 * since the last report (the first one's error in err). */
int state_write_behind_flush(char *err, size_t err_len);

/* Flushes, then stops the thread: state_file_replace() writes synchronously again. Returns as
 * state_write_behind_flush. */
int state_write_behind_stop(char *err, size_t err_len);

#endif
