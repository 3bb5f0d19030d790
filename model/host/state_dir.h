/* SPDX-License-Identifier: GPL-3.0-or-later */
/* The directory of the servos' EEPROM state files (`ax12-emu serve --state-dir`; the files
 * themselves: eeprom_store.h). */
#ifndef SIM_STATE_DIR_H
#define SIM_STATE_DIR_H

#include <stdbool.h>
#include <stddef.h>

/* $XDG_STATE_HOME/ax12 when XDG_STATE_HOME is an absolute path, else ~/.local/state/ax12
 * (./.local/state/ax12 without HOME). */
void state_dir_default(char *out, size_t len);

/* Creates dir (and its parents) if needed and checks that it accepts new files. False with a
 * one-line reason in err. */
bool state_dir_usable(const char *dir, char *err, size_t err_len);

#endif
